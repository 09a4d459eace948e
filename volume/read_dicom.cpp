// DICOM series through GDCM: the files of a directory grouped by SeriesInstanceUID, sorted by their
// position along the slice normal (gdcm::IPPSorter: ImagePositionPatient projected on the cross
// product of the ImageOrientationPatient cosines, not by file name or instance number), pixel data
// decoded by gdcm::ImageReader, rescale slope and intercept applied (CT: Hounsfield units).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>

#include <gdcmDirectory.h>
#include <gdcmIPPSorter.h>
#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmScanner.h>
#include <gdcmTag.h>
#include <gdcmTrace.h>

#include <glm/geometric.hpp>

#include "core/error.h"
#include "core/isolate.h"
#include "core/module.h"
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
            v.values.resize(v.voxelCount());
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

namespace {

// The volume as bytes, to cross from the reading process to ours: dims, the matrix, the strings, the values.
void put(std::string& out, const void* data, std::size_t size) {
    out.append(static_cast<const char*>(data), size);
}
void putString(std::string& out, const std::string& s) {
    const std::uint64_t n = s.size();
    put(out, &n, sizeof n);
    out += s;
}

}  // namespace

std::string serializeVolume(const DenseVolume& v) {
    std::string out;
    out.reserve(v.values.size() * sizeof(float) + 4096);  // one allocation for a 50 MB series, not a dozen
    put(out, v.dims.data(), sizeof v.dims);
    put(out, &v.indexToWorld, sizeof v.indexToWorld);
    const std::uint64_t files = v.files, notes = v.notes.size();
    put(out, &files, sizeof files);
    for (const std::string* s : {&v.format, &v.storedType, &v.units, &v.modality}) putString(out, *s);
    put(out, &notes, sizeof notes);
    for (const std::string& n : v.notes) putString(out, n);
    put(out, v.values.data(), v.values.size() * sizeof(float));
    return out;
}

namespace {

struct Reader {
    const std::string& bytes;
    const std::string& what;
    std::size_t at = 0;
    void get(void* data, std::size_t size) {
        if (size > bytes.size() - at) throw IoError(what + ": the DICOM reading process sent a short answer");
        std::memcpy(data, bytes.data() + at, size);
        at += size;
    }
    std::string getString() {
        std::uint64_t n = 0;
        get(&n, sizeof n);
        if (n > bytes.size() - at) throw IoError(what + ": the DICOM reading process sent a short answer");
        std::string s = bytes.substr(at, n);
        at += n;
        return s;
    }
};

}  // namespace

DenseVolume deserializeVolume(const std::string& bytes, const std::string& what) {
    DenseVolume v;
    Reader r{bytes, what};
    r.get(v.dims.data(), sizeof v.dims);
    r.get(&v.indexToWorld, sizeof v.indexToWorld);
    std::uint64_t files = 0, notes = 0;
    r.get(&files, sizeof files);
    v.files = files;
    for (std::string* s : {&v.format, &v.storedType, &v.units, &v.modality}) *s = r.getString();
    r.get(&notes, sizeof notes);
    for (std::uint64_t i = 0; i < notes; ++i) v.notes.push_back(r.getString());
    if ((bytes.size() - r.at) != v.voxelCount() * sizeof(float))
        throw IoError(what + ": the DICOM reading process sent a volume of the wrong size");
    v.values.resize(v.voxelCount());
    r.get(v.values.data(), v.values.size() * sizeof(float));
    return v;
}

std::uint64_t dicomMemoryLimit(const std::filesystem::path& dir) {
    // What the files could justify: 64 times their bytes (decoded floats, the copy the helper sends,
    // compressed pixel data), and 512 MiB for GDCM itself.
    std::uint64_t bytes = 0;
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(dir, ec))
        if (e.is_regular_file(ec)) bytes += e.file_size(ec);
    return (std::uint64_t(512) << 20) + 64 * bytes;
}

DenseVolume readDicomSeries(const std::filesystem::path& dir, const std::string& wantedSeries) {
    // GDCM (as Debian builds it) asserts on input it does not expect, which would end isoforge: it reads in
    // a helper program (core/isolate.h), and the volume comes back as bytes.
    const std::uint64_t limit = dicomMemoryLimit(dir);
    const auto program = helperProgram("isoforge-dicom-reader", "it reads DICOM series");
    return deserializeVolume(
        runHelper(dir.string(), "GDCM", program, {dir.string(), wantedSeries, std::to_string(limit)}), dir.string());
}

}  // namespace isoforge::volume::detail
