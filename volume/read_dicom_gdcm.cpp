// DICOM series through GDCM: the files of a directory grouped by SeriesInstanceUID, sorted by their
// position along the slice normal (gdcm::IPPSorter: ImagePositionPatient projected on the cross
// product of the ImageOrientationPatient cosines, not by file name or instance number), pixel data
// decoded by gdcm::ImageReader, rescale slope and intercept applied (CT: Hounsfield units).
// What the helper program isoforge-dicom-reader runs (volume/read_dicom.cpp starts it): its own library,
// isoforge_dicom_gdcm, so that isoforge itself neither loads GDCM nor pays for its start-up.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
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
#include "core/isolate.h"
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

namespace {

/// A series chosen, sorted and placed: what the scan of a directory gives, before any pixel is read.
struct Series {
    std::string uid;
    std::vector<std::string> files;  ///< sorted along the slice normal
    double zSpacing = 0;
    std::string modality, description, firstInstance, lastInstance;
    std::size_t notDicom = 0;
};

Series scanSeries(const std::filesystem::path& dir, const std::string& wantedSeries) {
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
    Series s;
    for (const std::string& f : files) {
        if (!scanner.IsKey(f.c_str())) {
            ++s.notDicom;
            continue;
        }
        bySeries[trimmed(scanner.GetValue(f.c_str(), kSeriesUid))].push_back(f);
    }
    if (bySeries.empty())
        throw IoError(dir.string() + ": none of its " + std::to_string(files.size()) + " files is a DICOM file");
    if (!wantedSeries.empty()) {
        for (const auto& [uid, list] : bySeries)
            if (uid.rfind(wantedSeries, 0) == 0) s.uid = uid;
        if (s.uid.empty()) throw IoError(dir.string() + ": no series with UID " + wantedSeries);
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
        s.uid = bySeries.begin()->first;
    }
    const std::vector<std::string>& slices = bySeries[s.uid];

    // Sort along the slice normal; the sorter also checks that every slice has the same orientation
    // and computes the spacing between slices.
    s.files = slices;
    if (slices.size() > 1) {
        for (const std::string& f : slices)
            if (!scanner.GetValue(f.c_str(), kPosition) || !scanner.GetValue(f.c_str(), kOrientation))
                throw IoError(f + ": no ImagePositionPatient / ImageOrientationPatient: cannot place the slice");
        gdcm::IPPSorter sorter;
        sorter.SetComputeZSpacing(true);
        sorter.SetZSpacingTolerance(1e-3);
        if (!sorter.Sort(slices))
            throw IoError(dir.string() + ": the " + std::to_string(slices.size()) + " slices of series " + s.uid +
                          " cannot be sorted along one normal (different orientations, or two slices at one position)");
        s.files = sorter.GetFilenames();
        s.zSpacing = sorter.GetZSpacing();
        if (!(s.zSpacing > 0))
            throw IoError(dir.string() + ": the slices of series " + s.uid +
                          " are not evenly spaced (a missing slice?); isoforge needs a regular grid");
    }
    s.modality = trimmed(scanner.GetValue(s.files.front().c_str(), kModality));
    s.description = trimmed(scanner.GetValue(s.files.front().c_str(), kSeriesDescription));
    s.firstInstance = trimmed(scanner.GetValue(s.files.front().c_str(), kInstanceNumber));
    s.lastInstance = trimmed(scanner.GetValue(s.files.back().c_str(), kInstanceNumber));
    return s;
}

/// One slice's size, type, geometry and rescale, as GDCM reads them.
struct Slice {
    std::int64_t w = 0, h = 0;
    std::string type;
    std::array<double, 3> origin{}, spacing{};
    std::array<double, 6> cosines{};
    double slope = 1, intercept = 0;
    bool rescaled() const { return slope != 1.0 || intercept != 0.0; }
};

/// Reads one slice, checks it, and writes its w x h pixels as floats (rescaled) to `where(slice)`, which
/// may refuse the slice (throw) once its size is known.
Slice readSlice(const std::string& f, const std::function<float*(const Slice&)>& where) {
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
    Slice s;
    s.w = img.GetDimension(0);
    s.h = img.GetDimension(1);
    const gdcm::PixelFormat pf = img.GetPixelFormat();
    if (pf.GetSamplesPerPixel() != 1)
        throw IoError(f + ": " + std::to_string(pf.GetSamplesPerPixel()) + " samples per pixel; expected grey");
    s.type = scalarTypeName(pf);
    if (s.type.empty())
        throw IoError(f + ": unsupported pixel type (" + std::to_string(pf.GetBitsAllocated()) + " bits allocated, " +
                      std::to_string(pf.GetBitsStored()) + " stored, pixel representation " +
                      std::to_string(pf.GetPixelRepresentation()) + ")");
    if (img.GetNumberOfDimensions() == 3 && img.GetDimension(2) > 1)
        throw IoError(f + ": a multi-frame image; this reader takes series of single-frame slices");
    const double* o = img.GetOrigin();
    const double* c = img.GetDirectionCosines();
    const double* sp = img.GetSpacing();
    for (int i = 0; i < 3; ++i) s.origin[std::size_t(i)] = o[i], s.spacing[std::size_t(i)] = sp[i];
    for (int i = 0; i < 6; ++i) s.cosines[std::size_t(i)] = c[i];
    s.slope = img.GetSlope();
    s.intercept = img.GetIntercept();
    float* out = where(s);
    // GDCM 3.0.21 (Debian 12's) copies a native slice's pixels by the image's size, not the data's, when
    // it swaps bytes or unpacks 12 bits (RAWCodec::DecodeBytes): it read past the end of a short pixel
    // data element (fuzz_dicom, AddressSanitizer; TALOS-2024-1944, fixed in GDCM 3.0.24). A native pixel
    // data element must hold the whole image before GDCM decodes it.
    if (const gdcm::ByteValue* bv = img.GetDataElement().GetByteValue()) {
        const std::uint64_t need =
            (std::uint64_t(s.w) * std::uint64_t(s.h) * pf.GetSamplesPerPixel() * pf.GetBitsAllocated() + 7) / 8;
        if (bv->GetLength() < need)
            throw IoError(f + ": the pixel data holds " + std::to_string(bv->GetLength()) + " bytes; " +
                          std::to_string(s.w) + " x " + std::to_string(s.h) + " pixels of " +
                          std::to_string(pf.GetBitsAllocated()) + " bits need " + std::to_string(need) +
                          " (truncated file?)");
    }
    std::vector<char> buffer(img.GetBufferLength());
    const std::size_t pixels = std::size_t(s.w) * std::size_t(s.h);
    if (buffer.size() < pixels * typeSize(s.type) || !img.GetBuffer(buffer.data()))
        throw IoError(f + ": the pixel data is shorter than " + std::to_string(s.w) + " x " + std::to_string(s.h) +
                      " pixels (truncated file?)");
    convertVoxels(buffer.data(), s.type, std::endian::native == std::endian::big, pixels, out);
    if (s.rescaled())
        for (std::size_t i = 0; i < pixels; ++i) out[i] = float(out[i] * s.slope + s.intercept);
    return s;
}

/// Checks slice k's size against the first's (k = 0: the volume's size against what isoforge reads).
void checkSliceSize(const std::filesystem::path& dir, const Series& series, std::size_t k, const Slice& first,
                    const Slice& s) {
    if (k == 0) {
        checkVolumeSize(dir, {s.w, s.h, std::int64_t(series.files.size())});
    } else if (s.w != first.w || s.h != first.h) {
        throw IoError(series.files[k] + ": " + std::to_string(s.w) + " x " + std::to_string(s.h) +
                      " pixels, but the series' slices are " + std::to_string(first.w) + " x " +
                      std::to_string(first.h));
    }
}

/// The volume without its voxels: size and placement from the first slice and the sorter's spacing; units
/// (HU for a rescaled CT) and notes.
DenseVolume header(const Series& series, const Slice& first, bool rescaled) {
    DenseVolume v;
    v.format = "DICOM";
    v.files = series.files.size();
    v.modality = series.modality;
    v.dims = {first.w, first.h, std::int64_t(series.files.size())};
    v.storedType = first.type;
    const auto& iop = first.cosines;
    const glm::dvec3 pixel(first.spacing[0], first.spacing[1],
                           series.zSpacing > 0 ? series.zSpacing : (first.spacing[2] > 0 ? first.spacing[2] : 1.0));
    const glm::dvec3 row(iop[0], iop[1], iop[2]), col(iop[3], iop[4], iop[5]);
    const glm::dvec3 normal = glm::normalize(glm::cross(row, col));
    v.indexToWorld =
        glm::dmat4(glm::dvec4(row * pixel.x, 0), glm::dvec4(col * pixel.y, 0), glm::dvec4(normal * pixel.z, 0),
                   glm::dvec4(first.origin[0], first.origin[1], first.origin[2], 1));
    if (v.modality == "CT" && rescaled) v.units = "HU";
    v.notes.push_back("series " + series.uid + (series.description.empty() ? "" : " (" + series.description + ")"));
    v.notes.push_back(
        "slices sorted along the normal: first " + std::filesystem::path(series.files.front()).filename().string() +
        " (instance " + series.firstInstance + "), last " +
        std::filesystem::path(series.files.back()).filename().string() + " (instance " + series.lastInstance + ")");
    if (rescaled)
        v.notes.push_back("rescale slope " + std::to_string(first.slope) + ", intercept " +
                          std::to_string(first.intercept));
    if (series.notDicom) v.notes.push_back(std::to_string(series.notDicom) + " non-DICOM files ignored");
    return v;
}

}  // namespace

DenseVolume readDicomSeriesHere(const std::filesystem::path& dir, const std::string& wantedSeries) {
    const Series series = scanSeries(dir, wantedSeries);
    std::vector<float> values;
    Slice first;
    bool rescaled = false;
    for (std::size_t k = 0; k < series.files.size(); ++k) {
        const Slice s = readSlice(series.files[k], [&](const Slice& got) {
            checkSliceSize(dir, series, k, first, got);
            const std::size_t pixels = std::size_t(got.w) * std::size_t(got.h);
            if (k == 0) resizeLarge(values, pixels * series.files.size());
            return values.data() + k * pixels;
        });
        if (k == 0) first = s;
        rescaled = rescaled || s.rescaled();
    }
    DenseVolume v = header(series, first, rescaled);
    v.values = std::move(values);
    return v;
}

void streamDicomSeriesHere(const std::filesystem::path& dir, const std::string& wantedSeries, bool headerOnly,
                           const HelperSend& send) {
    const Series series = scanSeries(dir, wantedSeries);
    std::vector<float> pixels;
    Slice first;
    for (std::size_t k = 0; k < series.files.size(); ++k) {
        const Slice s = readSlice(series.files[k], [&](const Slice& got) {
            checkSliceSize(dir, series, k, first, got);
            pixels.resize(std::size_t(got.w) * std::size_t(got.h));
            return pixels.data();
        });
        if (k == 0) {
            // Units and notes from the first slice's rescale (a whole read looks at every slice's).
            first = s;
            send(describeVolume(header(series, first, first.rescaled())));
            if (headerOnly) return;
        }
        HelperAnswer slice;
        slice.first = {{reinterpret_cast<const char*>(pixels.data()), pixels.size() * sizeof(float)}};
        send(slice);
    }
}

}  // namespace isoforge::volume::detail
