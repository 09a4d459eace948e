// DICOM series for isoforge: read by the helper program isoforge-dicom-reader (GDCM, which Debian builds with
// assertions, in a process of its own: volume/read_dicom_gdcm.cpp), and sent back as bytes.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "core/big_buffer.h"
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

std::string describeVolume(const DenseVolume& v) {
    std::string out;
    put(out, v.dims.data(), sizeof v.dims);
    put(out, &v.indexToWorld, sizeof v.indexToWorld);
    const std::uint64_t files = v.files, notes = v.notes.size();
    put(out, &files, sizeof files);
    for (const std::string* s : {&v.format, &v.storedType, &v.units, &v.modality}) putString(out, *s);
    put(out, &notes, sizeof notes);
    for (const std::string& n : v.notes) putString(out, n);
    const std::uint64_t size = out.size();
    put(out, &size, sizeof size);
    return out;
}

std::string serializeVolume(const DenseVolume& v) {
    std::string out(reinterpret_cast<const char*>(v.values.data()), v.values.size() * sizeof(float));
    out += describeVolume(v);
    return out;
}

namespace {

IoError shortAnswerError(const std::string& what) {
    return IoError(what + ": the DICOM reading process sent a short answer");
}

struct Reader {
    const char* bytes;
    std::size_t size;
    const std::string& what;
    std::size_t at = 0;
    [[noreturn]] void shortAnswer() const { throw shortAnswerError(what); }
    void get(void* data, std::size_t n) {
        if (n > size - at) shortAnswer();
        std::memcpy(data, bytes + at, n);
        at += n;
    }
    std::string getString() {
        std::uint64_t n = 0;
        get(&n, sizeof n);
        if (n > size - at) shortAnswer();
        std::string s(bytes + at, std::size_t(n));
        at += std::size_t(n);
        return s;
    }
};

}  // namespace

/// The volume an answer describes (its description ends the answer), without its voxels; `voxelBytes`
/// receives the size of what comes before the description.
DenseVolume describedVolume(const char* all, std::uint64_t bytes, const std::string& what, std::uint64_t& voxelBytes) {
    std::uint64_t described = 0;
    if (bytes < sizeof described) throw shortAnswerError(what);
    std::memcpy(&described, all + bytes - sizeof described, sizeof described);
    if (described > bytes - sizeof described) throw shortAnswerError(what);
    voxelBytes = bytes - sizeof described - described;
    DenseVolume v;
    Reader r{all + voxelBytes, std::size_t(described), what};
    r.get(v.dims.data(), sizeof v.dims);
    r.get(&v.indexToWorld, sizeof v.indexToWorld);
    std::uint64_t files = 0, notes = 0;
    r.get(&files, sizeof files);
    v.files = files;
    for (std::string* s : {&v.format, &v.storedType, &v.units, &v.modality}) *s = r.getString();
    r.get(&notes, sizeof notes);
    for (std::uint64_t i = 0; i < notes; ++i) v.notes.push_back(r.getString());
    if (r.at != r.size) throw IoError(what + ": the DICOM reading process sent a volume of the wrong size");
    return v;
}

DenseVolume volumeFromAnswer(std::vector<float> buffer, std::uint64_t bytes, const std::string& what) {
    if (bytes > buffer.size() * sizeof(float)) throw shortAnswerError(what);
    std::uint64_t voxelBytes = 0;
    DenseVolume v = describedVolume(reinterpret_cast<const char*>(buffer.data()), bytes, what, voxelBytes);
    if (voxelBytes != v.voxelCount() * sizeof(float))
        throw IoError(what + ": the DICOM reading process sent a volume of the wrong size");
    buffer.resize(v.voxelCount());  // drops the description's bytes: no new allocation
    v.values = std::move(buffer);
    return v;
}

DenseVolume deserializeVolume(const std::string& bytes, const std::string& what) {
    std::vector<float> buffer((bytes.size() + sizeof(float) - 1) / sizeof(float));
    std::memcpy(buffer.data(), bytes.data(), bytes.size());
    return volumeFromAnswer(std::move(buffer), bytes.size(), what);
}

std::uint64_t dicomMemoryLimit(const std::filesystem::path& dir, bool streamed) {
    // What the files could justify: 64 times their bytes (decoded floats, the copy the helper sends,
    // compressed pixel data), and 512 MiB for GDCM itself. A streamed read holds one slice at a time.
    std::uint64_t bytes = 0, largest = 0;
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(dir, ec))
        if (e.is_regular_file(ec)) {
            const std::uint64_t size = e.file_size(ec);
            bytes += size;
            largest = std::max(largest, size);
        }
    return (std::uint64_t(512) << 20) + 64 * (streamed ? largest : bytes);
}

namespace {

std::filesystem::path dicomHelper() {
    return helperProgram("isoforge-dicom-reader", "it reads DICOM series");
}

/// The helper's arguments for a streamed read ("header": the description alone).
std::vector<std::string> streamArguments(const std::filesystem::path& dir, const std::string& series,
                                         const char* mode) {
    return {dir.string(), series, std::to_string(dicomMemoryLimit(dir, true)), mode};
}

}  // namespace

VoxelSource dicomSource(const std::filesystem::path& dir, const std::string& series) {
    std::string answer;
    runHelper(dir.string(), "GDCM", dicomHelper(), streamArguments(dir, series, "header"), [&](std::uint64_t size) {
        answer.resize(std::size_t(size));
        return answer.data();
    });
    std::uint64_t voxelBytes = 0;
    VoxelSource s;
    s.header = describedVolume(answer.data(), answer.size(), dir.string(), voxelBytes);
    if (voxelBytes != 0) throw IoError(dir.string() + ": the DICOM reading process sent voxels with the header");
    s.dicomDirectory = dir;
    s.dicomSeries = series;
    return s;
}

DicomSlices::DicomSlices(const VoxelSource& source) : source_(source) {}
DicomSlices::~DicomSlices() = default;

void DicomSlices::read(std::int64_t count, float* out) {
    const DenseVolume& h = source_.header;
    const std::string what = source_.dicomDirectory.string();
    if (!helper_) {
        helper_ = std::make_unique<HelperStream>(
            what, "GDCM", dicomHelper(), streamArguments(source_.dicomDirectory, source_.dicomSeries, "stream"));
        std::string description;
        helper_->next([&](std::uint64_t size) {
            description.resize(std::size_t(size));
            return description.data();
        });
        std::uint64_t voxelBytes = 0;
        const DenseVolume again = describedVolume(description.data(), description.size(), what, voxelBytes);
        if (again.dims != h.dims || again.storedType != h.storedType)
            throw IoError(what +
                          ": the series changed while it was read (its slices are no longer those of its header)");
    }
    const std::uint64_t sliceBytes = std::uint64_t(h.dims[0]) * std::uint64_t(h.dims[1]) * sizeof(float);
    for (std::int64_t k = 0; k < count; ++k) {
        if (delivered_ >= h.dims[2]) throw IoError(what + ": read past the series' last slice");
        helper_->next([&](std::uint64_t size) {
            if (size != sliceBytes)
                throw IoError(what + ": the DICOM reading process sent a slice of " + std::to_string(size) +
                              " bytes; expected " + std::to_string(sliceBytes));
            return reinterpret_cast<char*>(out + std::size_t(k) * std::size_t(sliceBytes / sizeof(float)));
        });
        if (++delivered_ == h.dims[2]) helper_->finish();
    }
}

DenseVolume readDicomSeries(const std::filesystem::path& dir, const std::string& wantedSeries) {
    // GDCM (as Debian builds it) asserts on input it does not expect, which would end isoforge: it reads in
    // a helper program (core/isolate.h), and the volume comes back as bytes.
    const std::uint64_t limit = dicomMemoryLimit(dir);
    const auto program = dicomHelper();
    // The answer lands in the volume's own voxels (the description after them is cut off): one 50 MB buffer.
    std::vector<float> buffer;
    const std::uint64_t bytes = runHelper(
        dir.string(), "GDCM", program, {dir.string(), wantedSeries, std::to_string(limit)}, [&](std::uint64_t size) {
            resizeLarge(buffer, std::size_t((size + sizeof(float) - 1) / sizeof(float)));
            return reinterpret_cast<char*>(buffer.data());
        });
    return volumeFromAnswer(std::move(buffer), bytes, dir.string());
}

}  // namespace isoforge::volume::detail
