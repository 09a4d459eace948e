// DICOM series through GDCM: the files of a directory grouped by SeriesInstanceUID, sorted by their
// position along the slice normal (gdcm::IPPSorter: ImagePositionPatient projected on the cross
// product of the ImageOrientationPatient cosines, not by file name or instance number), pixel data
// decoded by gdcm::ImageReader, rescale slope and intercept applied (CT: Hounsfield units).
// What the helper program isoforge-dicom-reader runs (volume/read_dicom.cpp starts it): its own library,
// isoforge_dicom_gdcm, so that isoforge itself neither loads GDCM nor pays for its start-up.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <iostream>
#include <map>
#include <sstream>

#include <gdcmDirectory.h>
#include <gdcmIPPSorter.h>
#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmScanner.h>
#include <gdcmTag.h>
#include <gdcmTrace.h>

#include <glm/geometric.hpp>

#include "core/big_buffer.h"
#include "core/error.h"
#include "volume/dicom_layout.h"
#include "volume/readers.h"

namespace isoforge::volume::detail {

namespace {

const gdcm::Tag kSeriesUid(0x0020, 0x000e), kModality(0x0008, 0x0060), kSeriesDescription(0x0008, 0x103e),
    kInstanceNumber(0x0020, 0x0013), kOrientation(0x0020, 0x0037), kPosition(0x0020, 0x0032);

/// GDCM's warnings and errors go to `to` while it lives, then back to stderr (also when GDCM throws).
struct TraceTo {
    explicit TraceTo(std::ostream& to) {
        gdcm::Trace::SetWarningStream(to);
        gdcm::Trace::SetErrorStream(to);
    }
    ~TraceTo() {
        gdcm::Trace::SetWarningStream(std::cerr);
        gdcm::Trace::SetErrorStream(std::cerr);
    }
    TraceTo(const TraceTo&) = delete;
    TraceTo& operator=(const TraceTo&) = delete;
};

std::string trimmed(const char* s) {
    if (!s) return {};
    std::string t(s);
    while (!t.empty() && (t.back() == ' ' || t.back() == '\0')) t.pop_back();
    return t;
}

// The voxel type from the pixel module's numbers. Not PixelFormat::GetScalarType(): it asserts (ending the
// process, as Debian builds GDCM) on a bits stored past bits allocated and on other combinations a corrupt
// file holds (fuzz_dicom found it). "" for what isoforge does not read.
std::string scalarTypeName(const gdcm::PixelFormat& pf) {
    const unsigned allocated = pf.GetBitsAllocated(), stored = pf.GetBitsStored();
    const unsigned representation = pf.GetPixelRepresentation();
    if (stored == 0 || stored > allocated) return {};
    if (representation <= 1) {
        const bool sign = representation == 1;
        switch (allocated) {
            case 8:
                return sign ? "int8" : "uint8";
            case 12:  // packed 12-bit pixels, unpacked to 16 bits
            case 16:
                return sign ? "int16" : "uint16";
            case 32:
                return sign ? "int32" : "uint32";
            default:
                return {};
        }
    }
    if (representation == 3 && allocated == 32) return "float32";  // GDCM's codes for floating-point pixels
    if (representation == 4 && allocated == 64) return "float64";
    return {};
}

}  // namespace

DenseVolume readDicomSeriesHere(const std::filesystem::path& dir, const std::string& wantedSeries) {
    gdcm::Directory d;
    d.Load(dir.string(), false);
    std::vector<std::string> files = d.GetFilenames();
    std::sort(files.begin(), files.end());
    if (files.empty()) throw IoError(dir.string() + ": the directory holds no files (expected a DICOM series)");
    for (const std::string& f : files) checkDicomLayout(f);  // before GDCM asserts or allocates what they claim

    gdcm::Scanner scanner;
    for (const gdcm::Tag& t : {kSeriesUid, kModality, kSeriesDescription, kInstanceNumber, kOrientation, kPosition})
        scanner.AddTag(t);
    if (!scanner.Scan(files)) throw IoError(dir.string() + ": GDCM could not scan the directory");
    std::map<std::string, std::vector<std::string>> bySeries;
    std::vector<std::string> notDicom;
    for (const std::string& f : files) {
        if (!scanner.IsKey(f.c_str())) {
            notDicom.push_back(f);
            continue;
        }
        bySeries[trimmed(scanner.GetValue(f.c_str(), kSeriesUid))].push_back(f);
    }
    if (bySeries.empty())
        throw IoError(dir.string() + ": none of its " + std::to_string(files.size()) + " files is a DICOM file");
    std::string series;
    if (!wantedSeries.empty()) {
        for (const auto& [uid, list] : bySeries)
            if (uid.rfind(wantedSeries, 0) == 0) series = uid;
        if (series.empty()) throw IoError(dir.string() + ": no series with UID " + wantedSeries);
    } else if (bySeries.size() > 1) {
        std::string msg = dir.string() + ": the directory mixes " + std::to_string(bySeries.size()) +
                          " DICOM series; choose one with --series UID:";
        for (const auto& [uid, list] : bySeries) {
            msg += "\n  " + (uid.empty() ? std::string("(no SeriesInstanceUID)") : uid) + "  " +
                   std::to_string(list.size()) + (list.size() == 1 ? " file: " : " files, first: ") +
                   std::filesystem::path(list.front()).filename().string();
        }
        throw IoError(msg);
    } else {
        series = bySeries.begin()->first;
    }
    std::vector<std::string> slices = bySeries[series];

    // Sort along the slice normal; the sorter also checks that every slice has the same orientation
    // and computes the spacing between slices.
    std::vector<std::string> sorted = slices;
    double zSpacing = 0;
    if (slices.size() > 1) {
        for (const std::string& f : slices)
            if (!scanner.GetValue(f.c_str(), kPosition) || !scanner.GetValue(f.c_str(), kOrientation))
                throw IoError(f + ": no ImagePositionPatient / ImageOrientationPatient: cannot place the slice");
        gdcm::IPPSorter sorter;
        sorter.SetComputeZSpacing(true);
        sorter.SetZSpacingTolerance(1e-3);
        if (!sorter.Sort(slices))
            throw IoError(dir.string() + ": the " + std::to_string(slices.size()) + " slices of series " + series +
                          " cannot be sorted along one normal (different orientations, or two slices at one position)");
        sorted = sorter.GetFilenames();
        zSpacing = sorter.GetZSpacing();
        if (!(zSpacing > 0))
            throw IoError(dir.string() + ": the slices of series " + series +
                          " are not evenly spaced (a missing slice?); isoforge needs a regular grid");
    }

    DenseVolume v;
    v.format = "DICOM";
    v.files = sorted.size();
    v.modality = trimmed(scanner.GetValue(sorted.front().c_str(), kModality));
    std::array<double, 6> iop{1, 0, 0, 0, 1, 0};
    glm::dvec3 origin(0.0), pixel(1.0);
    bool rescaled = false;
    double slope0 = 1, intercept0 = 0;
    for (std::size_t k = 0; k < sorted.size(); ++k) {
        const std::string& f = sorted[k];
        gdcm::ImageReader reader;
        reader.SetFileName(f.c_str());
        // GDCM reads a file whose pixel data is cut short with only a warning (and zeros for the rest):
        // listen to its warnings and refuse such a slice.
        std::ostringstream warnings;
        bool read = false;
        {
            const TraceTo listen(warnings);
            read = reader.Read();
        }
        if (!read)
            throw IoError(f + ": GDCM cannot read the image (truncated or corrupt file, or an unsupported encoding)");
        if (warnings.str().find("Incomplete Pixel Data") != std::string::npos)
            throw IoError(f + ": the pixel data ends before the size its header gives (truncated file)");
        const gdcm::Image& img = reader.GetImage();
        const std::int64_t w = img.GetDimension(0), h = img.GetDimension(1);
        const gdcm::PixelFormat pf = img.GetPixelFormat();
        if (pf.GetSamplesPerPixel() != 1)
            throw IoError(f + ": " + std::to_string(pf.GetSamplesPerPixel()) + " samples per pixel; expected grey");
        const std::string type = scalarTypeName(pf);
        if (type.empty())
            throw IoError(f + ": unsupported pixel type (" + std::to_string(pf.GetBitsAllocated()) +
                          " bits allocated, " + std::to_string(pf.GetBitsStored()) + " stored, pixel representation " +
                          std::to_string(pf.GetPixelRepresentation()) + ")");
        if (img.GetNumberOfDimensions() == 3 && img.GetDimension(2) > 1)
            throw IoError(f + ": a multi-frame image; this reader takes series of single-frame slices");
        if (k == 0) {
            v.dims = {w, h, std::int64_t(sorted.size())};
            checkVolumeSize(dir, v.dims);
            resizeLarge(v.values, std::size_t(v.voxelCount()));
            v.storedType = type;
            const double* o = img.GetOrigin();
            const double* c = img.GetDirectionCosines();
            const double* s = img.GetSpacing();
            origin = {o[0], o[1], o[2]};
            for (int i = 0; i < 6; ++i) iop[std::size_t(i)] = c[i];
            pixel = {s[0], s[1], zSpacing > 0 ? zSpacing : (s[2] > 0 ? s[2] : 1.0)};
            slope0 = img.GetSlope();
            intercept0 = img.GetIntercept();
        } else if (w != v.dims[0] || h != v.dims[1]) {
            throw IoError(f + ": " + std::to_string(w) + " x " + std::to_string(h) +
                          " pixels, but the series' slices are " + std::to_string(v.dims[0]) + " x " +
                          std::to_string(v.dims[1]));
        }
        // GDCM 3.0.21 (Debian 12's) copies a native slice's pixels by the image's size, not the data's, when
        // it swaps bytes or unpacks 12 bits (RAWCodec::DecodeBytes): it read past the end of a short pixel
        // data element (fuzz_dicom, AddressSanitizer; TALOS-2024-1944, fixed in GDCM 3.0.24). A native pixel
        // data element must hold the whole image before GDCM decodes it.
        if (const gdcm::ByteValue* bv = img.GetDataElement().GetByteValue()) {
            const std::uint64_t need =
                (std::uint64_t(w) * std::uint64_t(h) * pf.GetSamplesPerPixel() * pf.GetBitsAllocated() + 7) / 8;
            if (bv->GetLength() < need)
                throw IoError(f + ": the pixel data holds " + std::to_string(bv->GetLength()) + " bytes; " +
                              std::to_string(w) + " x " + std::to_string(h) + " pixels of " +
                              std::to_string(pf.GetBitsAllocated()) + " bits need " + std::to_string(need) +
                              " (truncated file?)");
        }
        std::vector<char> buffer(img.GetBufferLength());
        const std::size_t pixels = std::size_t(w) * std::size_t(h);
        if (buffer.size() < pixels * typeSize(type) || !img.GetBuffer(buffer.data()))
            throw IoError(f + ": the pixel data is shorter than " + std::to_string(w) + " x " + std::to_string(h) +
                          " pixels (truncated file?)");
        float* out = v.values.data() + k * pixels;
        convertVoxels(buffer.data(), type, std::endian::native == std::endian::big, pixels, out);
        const double slope = img.GetSlope(), intercept = img.GetIntercept();
        if (slope != 1.0 || intercept != 0.0) {
            rescaled = true;
            for (std::size_t i = 0; i < pixels; ++i) out[i] = float(out[i] * slope + intercept);
        }
    }
    const glm::dvec3 row(iop[0], iop[1], iop[2]), col(iop[3], iop[4], iop[5]);
    const glm::dvec3 normal = glm::normalize(glm::cross(row, col));
    v.indexToWorld = glm::dmat4(glm::dvec4(row * pixel.x, 0), glm::dvec4(col * pixel.y, 0),
                                glm::dvec4(normal * pixel.z, 0), glm::dvec4(origin, 1));
    if (v.modality == "CT" && rescaled) v.units = "HU";
    v.notes.push_back("series " + series +
                      (trimmed(scanner.GetValue(sorted.front().c_str(), kSeriesDescription)).empty()
                           ? std::string()
                           : " (" + trimmed(scanner.GetValue(sorted.front().c_str(), kSeriesDescription)) + ")"));
    v.notes.push_back("slices sorted along the normal: first " +
                      std::filesystem::path(sorted.front()).filename().string() + " (instance " +
                      trimmed(scanner.GetValue(sorted.front().c_str(), kInstanceNumber)) + "), last " +
                      std::filesystem::path(sorted.back()).filename().string() + " (instance " +
                      trimmed(scanner.GetValue(sorted.back().c_str(), kInstanceNumber)) + ")");
    if (rescaled)
        v.notes.push_back("rescale slope " + std::to_string(slope0) + ", intercept " + std::to_string(intercept0));
    if (!notDicom.empty()) v.notes.push_back(std::to_string(notDicom.size()) + " non-DICOM files ignored");
    return v;
}

}  // namespace isoforge::volume::detail
