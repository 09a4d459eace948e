#include "volume/dense_volume.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <utility>
#include <vector>

#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "core/big_buffer.h"
#include "core/error.h"
#include "volume/readers.h"
#include "volume/sample.h"

namespace isoforge::volume {

glm::dvec3 DenseVolume::spacing() const {
    return {glm::length(glm::dvec3(indexToWorld[0])), glm::length(glm::dvec3(indexToWorld[1])),
            glm::length(glm::dvec3(indexToWorld[2]))};
}

glm::dmat3 DenseVolume::directions() const {
    glm::dmat3 d;
    for (int c = 0; c < 3; ++c) {
        const glm::dvec3 col(indexToWorld[c]);
        const double len = glm::length(col);
        d[c] = len > 0 ? col / len : glm::dvec3(0.0);
    }
    return d;
}

std::string DenseVolume::orientationCode() const {
    const glm::dmat3 d = directions();
    std::string code;
    for (int c = 0; c < 3; ++c) {
        int axis = 0;
        for (int a = 1; a < 3; ++a)
            if (std::abs(d[c][a]) > std::abs(d[c][axis])) axis = a;
        static const char positive[] = {'L', 'P', 'S'}, negative[] = {'R', 'A', 'I'};
        code += d[c][axis] >= 0 ? positive[axis] : negative[axis];
    }
    return code;
}

std::pair<float, float> DenseVolume::range() const {
    if (values.empty()) return {0.f, 0.f};
    float lo = values[0], hi = values[0];
    detail::extendRange(values.data(), values.size(), lo, hi);
    return {lo, hi};
}

namespace {

std::string lowerName(const std::filesystem::path& p) {
    std::string s = p.filename().string();
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return s;
}

bool endsWith(const std::string& s, const std::string& e) {
    return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
}

}  // namespace

bool isVolumePath(const std::filesystem::path& path) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) return true;
    const std::string n = lowerName(path);
    for (const char* e : {".nii", ".nii.gz", ".nrrd", ".nhdr", ".mha", ".mhd", ".raw", ".vdb", ".dcm"})
        if (endsWith(n, e)) return true;
    return false;
}

DenseVolume readVolume(const std::filesystem::path& path, const VolumeReadOptions& o) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw IoError(path.string() + ": no such file or directory");
    if (std::filesystem::is_directory(path, ec)) return detail::readDicomSeries(path, o.dicomSeries);
    if (!std::filesystem::is_regular_file(path, ec)) throw IoError(path.string() + ": not a regular file");
    const std::string n = lowerName(path);
    if (endsWith(n, ".nii") || endsWith(n, ".nii.gz")) return detail::readNifti(path);
    if (endsWith(n, ".nrrd") || endsWith(n, ".nhdr")) return detail::readNrrd(path);
    if (endsWith(n, ".mha") || endsWith(n, ".mhd")) return detail::readMetaImage(path);
    if (endsWith(n, ".raw")) return detail::readRaw(path, o);
    if (endsWith(n, ".vdb")) return detail::readVdbVolume(path, o.vdbGrid);
    if (endsWith(n, ".dcm")) return detail::readDicomSeries(path.parent_path(), o.dicomSeries);
    throw IoError(path.string() +
                  ": unknown volume format (expected .nii, .nii.gz, .nrrd, .nhdr, .mha, .mhd, .raw, .vdb or a DICOM "
                  "directory)");
}

namespace detail {

// ---------------------------------------------------------------------------------------------
// raw

namespace {
/// Bytes per voxel of the raw options' type. @throw IoError without --dims and --type, or for an unknown type
std::size_t rawVoxelBytes(const std::filesystem::path& path, const VolumeReadOptions& o) {
    if (o.rawDims[0] <= 0 || o.rawType.empty())
        throw IoError(path.string() + ": raw voxels need --dims X,Y,Z and --type (uint8, int16, float32, ...)");
    const std::size_t bytesPer = typeSize(o.rawType);
    if (!bytesPer) throw IoError(path.string() + ": unknown --type '" + o.rawType + "'");
    return bytesPer;
}
}  // namespace

DenseVolume readRaw(const std::filesystem::path& path, const VolumeReadOptions& o) {
    const std::size_t bytesPer = rawVoxelBytes(path, o);
    checkVolumeSize(path, o.rawDims);
    DenseVolume v;
    v.dims = o.rawDims;
    const std::uint64_t need = o.rawOffset + v.voxelCount() * bytesPer;
    const std::uint64_t have = std::filesystem::file_size(path);
    if (have < need)
        throw IoError(path.string() + ": " + std::to_string(v.dims[0]) + " x " + std::to_string(v.dims[1]) + " x " +
                      std::to_string(v.dims[2]) + " " + o.rawType + " voxels after " + std::to_string(o.rawOffset) +
                      " bytes need " + std::to_string(need) + " bytes; the file has " + std::to_string(have));
    std::ifstream in(path, std::ios::binary);
    in.seekg(std::streamoff(o.rawOffset));
    std::vector<char> bytes(v.voxelCount() * bytesPer);
    in.read(bytes.data(), std::streamsize(bytes.size()));
    if (!in) throw IoError(path.string() + ": read error");
    resizeLarge(v.values, std::size_t(v.voxelCount()));
    convertVoxels(bytes.data(), o.rawType, o.rawBigEndian, v.voxelCount(), v.values.data());
    v.indexToWorld = glm::dmat4(1.0);
    for (int a = 0; a < 3; ++a) v.indexToWorld[a][a] = o.rawSpacing[a];
    v.format = "raw";
    v.storedType = o.rawType;
    return v;
}

VoxelSource rawSource(const std::filesystem::path& path, const VolumeReadOptions& o) {
    const std::size_t bytesPer = rawVoxelBytes(path, o);
    checkVolumeDims(path, o.rawDims);
    VoxelSource s;
    DenseVolume& v = s.header;
    v.dims = o.rawDims;
    for (int a = 0; a < 3; ++a) v.indexToWorld[a][a] = o.rawSpacing[a];
    v.format = "raw";
    v.storedType = o.rawType;
    s.parts.push_back({path, o.rawOffset, 0, v.voxelCount() * bytesPer, false});
    s.bigEndian = o.rawBigEndian;
    return s;
}

namespace {
void scanRange(const float* v, std::size_t count, float& lo, float& hi) {
    float a = lo, b = hi;
    for (std::size_t i = 0; i < count; ++i) {
        a = v[i] < a ? v[i] : a;
        b = b < v[i] ? v[i] : b;
    }
    lo = a;
    hi = b;
}
}  // namespace

void extendRange(const float* v, std::size_t count, float& lo, float& hi) {
    // In fixed chunks on all threads, then the chunks' ranges in order with the same rule: a value
    // replaces the range's end only when strictly beyond it, so the answer (signed zeros and NaNs
    // included) is the one scan's, whatever the thread count.
    constexpr std::size_t kChunk = std::size_t{1} << 18;
    if (count <= kChunk) return scanRange(v, count, lo, hi);
    const std::size_t chunks = (count + kChunk - 1) / kChunk;
    const float inf = std::numeric_limits<float>::infinity();
    std::vector<std::pair<float, float>> part(chunks, {inf, -inf});
    part[0] = {lo, hi};
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
        scanRange(v + c * kChunk, std::min(kChunk, count - c * kChunk), part[c].first, part[c].second);
    });
    for (const auto& [a, b] : part) {
        lo = a < lo ? a : lo;
        hi = hi < b ? b : hi;
    }
}

}  // namespace detail

}  // namespace isoforge::volume
