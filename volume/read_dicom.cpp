// DICOM series for isoforge: read by the helper program isoforge-dicom-reader (GDCM, which Debian builds with
// assertions, in a process of its own: volume/read_dicom_gdcm.cpp), and sent back as bytes.
#include <cstdint>
#include <cstring>
#include <string>

#include "core/error.h"
#include "core/isolate.h"
#include "core/module.h"
#include "volume/readers.h"

namespace isoforge::volume::detail {

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
