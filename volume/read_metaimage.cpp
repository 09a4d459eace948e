// MetaImage (.mha, .mhd): "Key = value" lines, then the voxels (after ElementDataFile = LOCAL) or in a
// separate file, raw or zlib-compressed (CompressedData = True).
#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include <zlib.h>

#include "core/big_buffer.h"
#include "core/error.h"
#include "volume/readers.h"

namespace isoforge::volume::detail {

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

namespace {

/// A MetaImage header and where its voxels are.
struct MetaHeader {
    DenseVolume v;  ///< everything but the values
    bool msb = false, compressed = false;
    std::filesystem::path dataPath;
    std::uint64_t dataOffset = 0;  ///< where the voxels (or their stream) start in dataPath
    std::uint64_t dataSize = 0;    ///< bytes from there to the end of dataPath
};

MetaHeader readHeader(const std::filesystem::path& path) {
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
    MetaHeader mh;
    DenseVolume& v = mh.v;
    v.format = "MetaImage";
    const auto dimSize = require("dimsize", "DimSize");
    const auto dims = numbers(path, dimSize.second, "DimSize", dimSize.first, nd);
    for (double d : dims)
        if (!(d >= 1 && d <= double(1 << 20)) || d != std::floor(d))
            throw IoError(path.string() + ":" + std::to_string(dimSize.second) +
                          ": DimSize: expected whole numbers from 1 to 1,048,576, found '" + dimSize.first + "'");
    v.dims = {std::int64_t(dims[0]), std::int64_t(dims[1]), nd == 3 ? std::int64_t(dims[2]) : 1};
    checkVolumeDims(path, v.dims);
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

    for (const char* k : {"binarydatabyteordermsb", "elementbyteordermsb"})
        if (const auto* m = get(k)) mh.msb = m->first == "True" || m->first == "true" || m->first == "1";
    mh.compressed =
        get("compresseddata") && (get("compresseddata")->first == "True" || get("compresseddata")->first == "true");
    const auto file = require("elementdatafile", "ElementDataFile");
    std::error_code ec;
    if (file.first == "LOCAL") {
        mh.dataPath = path;
        const std::streamoff at = in.tellg();
        mh.dataOffset = at < 0 ? std::filesystem::file_size(path, ec) : std::uint64_t(at);
    } else {
        if (file.first.find('%') != std::string::npos || file.first == "LIST")
            throw IoError(path.string() + ":" + std::to_string(file.second) +
                          ": ElementDataFile lists several files; only one data file is supported");
        mh.dataPath = path.parent_path() / file.first;
        // A directory opens as a stream on Linux and then throws from inside the read (found by
        // tests/fuzz_volume_readers.cpp: "ElementDataFile = ." ended the process).
        if (!std::filesystem::is_regular_file(mh.dataPath, ec))
            throw IoError(path.string() + ":" + std::to_string(file.second) + ": the data file " +
                          mh.dataPath.string() + " is not a regular file");
        if (!std::ifstream(mh.dataPath, std::ios::binary))
            throw IoError(path.string() + ":" + std::to_string(file.second) + ": cannot open the data file " +
                          mh.dataPath.string());
        v.files = 2;
    }
    const std::uint64_t size = std::filesystem::file_size(mh.dataPath, ec);
    mh.dataSize = ec || size < mh.dataOffset ? 0 : size - mh.dataOffset;
    return mh;
}

std::string shortData(const MetaHeader& mh, std::uint64_t bytes) {
    const DenseVolume& v = mh.v;
    return mh.dataPath.string() + ": the header promises " + std::to_string(v.dims[0]) + " x " +
           std::to_string(v.dims[1]) + " x " + std::to_string(v.dims[2]) + " " + v.storedType + " voxels (" +
           std::to_string(bytes) + " bytes) but the data holds " + std::to_string(mh.dataSize) + " bytes";
}

}  // namespace

DenseVolume readMetaImage(const std::filesystem::path& path) {
    MetaHeader mh = readHeader(path);
    DenseVolume& v = mh.v;
    checkVolumeSize(path, v.dims);
    const std::size_t bytes = v.voxelCount() * typeSize(v.storedType);
    std::ifstream d(mh.dataPath, std::ios::binary);
    d.seekg(std::streamoff(mh.dataOffset));
    std::string payload;
    payload.assign(std::istreambuf_iterator<char>(d), std::istreambuf_iterator<char>());
    std::vector<char> raw;
    const char* voxels = payload.data();
    if (mh.compressed) {
        raw = inflateExactly(mh.dataPath, payload.data(), payload.size(), bytes);
        voxels = raw.data();
    } else {
        if (payload.size() < bytes) throw IoError(shortData(mh, bytes));
        voxels = payload.data() + (payload.size() - bytes);  // HeaderSize = -1 semantics: the data ends the file
    }
    resizeLarge(v.values, std::size_t(v.voxelCount()));
    convertVoxels(voxels, v.storedType, mh.msb, v.voxelCount(), v.values.data());
    return std::move(mh.v);
}

VoxelSource metaImageSource(const std::filesystem::path& path) {
    MetaHeader mh = readHeader(path);
    VoxelSource s;
    s.header = std::move(mh.v);
    s.bigEndian = mh.msb;
    VoxelSource::Part p;
    p.file = mh.dataPath;
    p.bytes = s.header.voxelCount() * typeSize(s.header.storedType);
    p.compressed = mh.compressed;
    if (!mh.compressed && mh.dataSize < p.bytes) throw IoError(shortData(mh, p.bytes));
    p.offset = mh.compressed ? mh.dataOffset : mh.dataOffset + (mh.dataSize - p.bytes);
    s.parts.push_back(p);
    return s;
}

}  // namespace isoforge::volume::detail
