#include "volume/dense_volume.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include <zlib.h>

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
    const auto [lo, hi] = std::minmax_element(values.begin(), values.end());
    return {*lo, *hi};
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

DenseVolume readRaw(const std::filesystem::path& path, const VolumeReadOptions& o) {
    if (o.rawDims[0] <= 0 || o.rawType.empty())
        throw IoError(path.string() + ": raw voxels need --dims X,Y,Z and --type (uint8, int16, float32, ...)");
    const std::size_t bytesPer = typeSize(o.rawType);
    if (!bytesPer) throw IoError(path.string() + ": unknown --type '" + o.rawType + "'");
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

// ---------------------------------------------------------------------------------------------
// MetaImage: "Key = value" lines, then the voxels (after ElementDataFile = LOCAL) or in a separate file.

namespace {

std::string trim(const std::string& s) {
    const auto b = s.find_first_not_of(" \t\r");
    if (b == std::string::npos) return {};
    return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}

std::vector<double> numbers(const std::filesystem::path& path, int line, const std::string& key,
                            const std::string& value, std::size_t count) {
    std::istringstream in(value);
    std::vector<double> out;
    std::string word;
    while (in >> word) {
        char* end = nullptr;
        const double d = std::strtod(word.c_str(), &end);
        if (end == word.c_str() || *end != '\0' || !std::isfinite(d))
            throw IoError(path.string() + ":" + std::to_string(line) + ": " + key + ": expected " +
                          std::to_string(count) + " numbers, found '" + word + "'");
        out.push_back(d);
    }
    if (out.size() != count)
        throw IoError(path.string() + ":" + std::to_string(line) + ": " + key + ": expected " + std::to_string(count) +
                      " numbers, found " + std::to_string(out.size()));
    return out;
}

std::string metaType(const std::string& t) {
    static const std::map<std::string, std::string> types = {
        {"MET_UCHAR", "uint8"},   {"MET_CHAR", "int8"},      {"MET_USHORT", "uint16"},     {"MET_SHORT", "int16"},
        {"MET_UINT", "uint32"},   {"MET_INT", "int32"},      {"MET_ULONG", "uint32"},      {"MET_LONG", "int32"},
        {"MET_FLOAT", "float32"}, {"MET_DOUBLE", "float64"}, {"MET_ULONG_LONG", "uint64"}, {"MET_LONG_LONG", "int64"}};
    auto it = types.find(t);
    return it == types.end() ? std::string() : it->second;
}

}  // namespace

/// Inflates a zlib (or gzip) stream of exactly `expected` bytes. @throw IoError if it is cut short or corrupt.
std::vector<char> inflateExactly(const std::filesystem::path& path, const char* data, std::size_t size,
                                 std::size_t expected) {
    std::vector<char> out(expected);
    z_stream z{};
    if (inflateInit2(&z, 15 + 32) != Z_OK) throw IoError(path.string() + ": zlib initialisation failed");
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data));
    z.avail_in = static_cast<uInt>(std::min<std::size_t>(size, std::numeric_limits<uInt>::max()));
    std::size_t produced = 0;
    int rc = Z_OK;
    while (rc == Z_OK && produced < expected) {
        z.next_out = reinterpret_cast<Bytef*>(out.data() + produced);
        const std::size_t chunk = std::min<std::size_t>(expected - produced, 1u << 30);
        z.avail_out = static_cast<uInt>(chunk);
        rc = inflate(&z, Z_NO_FLUSH);
        produced += chunk - z.avail_out;
        if (rc == Z_BUF_ERROR && z.avail_in == 0) break;
    }
    inflateEnd(&z);
    if (rc != Z_OK && rc != Z_STREAM_END && !(rc == Z_BUF_ERROR && produced < expected))
        throw IoError(path.string() + ": compressed voxel data is corrupt (zlib: " + (z.msg ? z.msg : "error") +
                      ") after " + std::to_string(produced) + " of " + std::to_string(expected) + " bytes");
    if (produced < expected)
        throw IoError(path.string() + ": compressed voxel data ends after " + std::to_string(produced) + " of the " +
                      std::to_string(expected) + " bytes the header promises (truncated file?)");
    return out;
}

DenseVolume readMetaImage(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError(path.string() + ": cannot open");
    std::map<std::string, std::pair<std::string, int>> keys;  // lower-cased key -> value, line
    std::string line;
    int lineNo = 0;
    std::string dataFile;
    while (std::getline(in, line)) {
        ++lineNo;
        if (lineNo > 200) throw IoError(path.string() + ": no ElementDataFile within 200 header lines");
        const auto eq = line.find('=');
        if (eq == std::string::npos) {
            if (trim(line).empty()) continue;
            throw IoError(path.string() + ":" + std::to_string(lineNo) + ": expected 'Key = value', found '" +
                          trim(line).substr(0, 60) + "'");
        }
        std::string key = trim(line.substr(0, eq));
        std::transform(key.begin(), key.end(), key.begin(), [](unsigned char c) { return char(std::tolower(c)); });
        keys[key] = {trim(line.substr(eq + 1)), lineNo};
        if (key == "elementdatafile") break;  // the last header line
    }
    auto get = [&](const std::string& k) -> const std::pair<std::string, int>* {
        auto it = keys.find(k);
        return it == keys.end() ? nullptr : &it->second;
    };
    auto require = [&](const std::string& k, const char* name) {
        const auto* v = get(k);
        if (!v) throw IoError(path.string() + ": the MetaImage header has no " + name);
        return *v;
    };
    const auto ndims = require("ndims", "NDims");
    if (ndims.first != "3" && ndims.first != "2")
        throw IoError(path.string() + ":" + std::to_string(ndims.second) + ": NDims: expected 2 or 3, found '" +
                      ndims.first + "'");
    const std::size_t nd = ndims.first == "3" ? 3 : 2;
    DenseVolume v;
    v.format = "MetaImage";
    const auto dimSize = require("dimsize", "DimSize");
    const auto dims = numbers(path, dimSize.second, "DimSize", dimSize.first, nd);
    for (double d : dims)
        if (!(d >= 1 && d <= double(1 << 20)) || d != std::floor(d))
            throw IoError(path.string() + ":" + std::to_string(dimSize.second) +
                          ": DimSize: expected whole numbers from 1 to 1,048,576, found '" + dimSize.first + "'");
    v.dims = {std::int64_t(dims[0]), std::int64_t(dims[1]), nd == 3 ? std::int64_t(dims[2]) : 1};
    checkVolumeSize(path, v.dims);
    const auto type = require("elementtype", "ElementType");
    v.storedType = metaType(type.first);
    if (v.storedType.empty())
        throw IoError(path.string() + ":" + std::to_string(type.second) + ": ElementType: unsupported '" + type.first +
                      "' (expected MET_UCHAR, MET_SHORT, MET_FLOAT, ...)");
    if (const auto* c = get("elementnumberofchannels"); c && c->first != "1")
        throw IoError(path.string() + ":" + std::to_string(c->second) + ": only one channel per voxel is supported");
    glm::dvec3 spacing(1.0);
    if (const auto* s = get("elementspacing") ? get("elementspacing") : get("elementsize")) {
        const auto sp = numbers(path, s->second, "ElementSpacing", s->first, nd);
        for (std::size_t a = 0; a < nd; ++a) spacing[int(a)] = sp[a];
    }
    glm::dmat3 dir(1.0);
    for (const char* k : {"transformmatrix", "rotation", "orientation"})
        if (const auto* m = get(k)) {
            const auto t = numbers(path, m->second, k, m->first, nd * nd);
            for (std::size_t r = 0; r < nd; ++r)  // each row: the direction of one index axis (as ITK writes)
                for (std::size_t c = 0; c < nd; ++c) dir[int(r)][int(c)] = t[r * nd + c];
            break;
        }
    glm::dvec3 origin(0.0);
    for (const char* k : {"offset", "origin", "position"})
        if (const auto* m = get(k)) {
            const auto t = numbers(path, m->second, k, m->first, nd);
            for (std::size_t a = 0; a < nd; ++a) origin[int(a)] = t[a];
            break;
        }
    for (int a = 0; a < 3; ++a) v.indexToWorld[a] = glm::dvec4(dir[a] * spacing[a], 0.0);
    v.indexToWorld[3] = glm::dvec4(origin, 1.0);
    if (const auto* ao = get("anatomicalorientation")) v.notes.push_back("AnatomicalOrientation " + ao->first);

    bool msb = false;
    for (const char* k : {"binarydatabyteordermsb", "elementbyteordermsb"})
        if (const auto* m = get(k)) msb = m->first == "True" || m->first == "true" || m->first == "1";
    const bool compressed =
        get("compresseddata") && (get("compresseddata")->first == "True" || get("compresseddata")->first == "true");
    const auto file = require("elementdatafile", "ElementDataFile");
    const std::size_t bytes = v.voxelCount() * typeSize(v.storedType);
    std::string payload;
    std::filesystem::path dataPath = path;
    if (file.first == "LOCAL") {
        payload.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    } else {
        if (file.first.find('%') != std::string::npos || file.first == "LIST")
            throw IoError(path.string() + ":" + std::to_string(file.second) +
                          ": ElementDataFile lists several files; only one data file is supported");
        dataPath = path.parent_path() / file.first;
        // A directory opens as a stream on Linux and then throws from inside the read (found by
        // tests/fuzz_volume_readers.cpp: "ElementDataFile = ." ended the process).
        std::error_code ec;
        if (!std::filesystem::is_regular_file(dataPath, ec))
            throw IoError(path.string() + ":" + std::to_string(file.second) + ": the data file " + dataPath.string() +
                          " is not a regular file");
        std::ifstream d(dataPath, std::ios::binary);
        if (!d)
            throw IoError(path.string() + ":" + std::to_string(file.second) + ": cannot open the data file " +
                          dataPath.string());
        payload.assign(std::istreambuf_iterator<char>(d), std::istreambuf_iterator<char>());
        v.files = 2;
    }
    std::vector<char> raw;
    const char* voxels = payload.data();
    if (compressed) {
        raw = inflateExactly(dataPath, payload.data(), payload.size(), bytes);
        voxels = raw.data();
    } else {
        if (payload.size() < bytes)
            throw IoError(dataPath.string() + ": the header promises " + std::to_string(v.dims[0]) + " x " +
                          std::to_string(v.dims[1]) + " x " + std::to_string(v.dims[2]) + " " + v.storedType +
                          " voxels (" + std::to_string(bytes) + " bytes) but the data holds " +
                          std::to_string(payload.size()) + " bytes");
        voxels = payload.data() + (payload.size() - bytes);  // HeaderSize = -1 semantics: the data ends the file
    }
    resizeLarge(v.values, std::size_t(v.voxelCount()));
    convertVoxels(voxels, v.storedType, msb, v.voxelCount(), v.values.data());
    return v;
}

}  // namespace detail

}  // namespace isoforge::volume
