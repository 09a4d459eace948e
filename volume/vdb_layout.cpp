#include "volume/vdb_layout.h"

#include <map>
#include <string>

#include "core/error.h"

namespace isoforge::volume::detail {

namespace {

class Walker {
public:
    Walker(std::istream& in, std::uint64_t size, const std::filesystem::path& path)
        : in_(in), size_(size), path_(path) {}

    std::uint64_t at() const { return at_; }
    std::uint64_t left() const { return size_ - at_; }

    [[noreturn]] void fail(const std::string& what, std::uint64_t where) const {
        throw IoError(path_.string() + ": byte " + std::to_string(where) + ": corrupt VDB file: " + what);
    }
    void need(std::uint64_t n, const std::string& what) const {
        if (n > left())
            fail(what + " needs " + std::to_string(n) + " bytes, the file has " + std::to_string(left()) + " left",
                 at_);
    }
    void seek(std::uint64_t to) {
        in_.clear();
        in_.seekg(std::streamoff(to));
        at_ = to;
    }
    void skip(std::uint64_t n, const std::string& what) {
        need(n, what);
        seek(at_ + n);
    }
    template <typename T>
    T get(const std::string& what) {
        need(sizeof(T), what);
        T v{};
        in_.read(reinterpret_cast<char*>(&v), sizeof(T));
        if (!in_) fail("cannot read " + what, at_);
        at_ += sizeof(T);
        return v;
    }
    std::string string(const std::string& what) {
        const auto n = get<std::uint32_t>(what + "'s length");
        need(n, what);
        std::string s(n, '\0');
        if (n && !in_.read(s.data(), n)) fail("cannot read " + what, at_);
        at_ += n;
        return s;
    }

private:
    std::istream& in_;
    std::uint64_t size_, at_ = 0;
    const std::filesystem::path& path_;
};

// The bytes each fixed-size metadata type reads (TypedMetadata<T>::readValue reads sizeof(T), whatever the
// stored byte count says).
const std::map<std::string, std::uint32_t>& fixedSizes() {
    static const std::map<std::string, std::uint32_t> sizes = {
        {"bool", 1},   {"int32", 4},  {"int64", 8},  {"float", 4},  {"double", 8}, {"vec2i", 8},
        {"vec2s", 8},  {"vec2d", 16}, {"vec3i", 12}, {"vec3s", 12}, {"vec3d", 24}, {"vec4i", 16},
        {"vec4s", 16}, {"vec4d", 32}, {"mat4s", 64}, {"mat4d", 128}};
    return sizes;
}

// A blosc buffer's header holds its uncompressed size at bytes 4..7 and its own size at 12..15, which blosc
// 1.21 trusts as the buffer's when it decompresses (its API takes no source size): a header claiming more
// than the buffer holds made it read past OpenVDB's buffer (fuzz_vdb: SEGV in libblosc, from
// DelayedLoadMetadata::readValue).
std::uint32_t bloscUncompressed(Walker& w, std::uint32_t bytes, const std::string& what) {
    if (bytes < 16) w.fail(what + ": a blosc buffer of " + std::to_string(bytes) + " bytes", w.at());
    const std::uint64_t start = w.at();
    w.get<std::uint32_t>(what);
    const auto n = w.get<std::uint32_t>(what);
    w.get<std::uint32_t>(what);
    const auto claimed = w.get<std::uint32_t>(what);
    if (claimed > bytes)
        w.fail(what + ": a blosc buffer of " + std::to_string(bytes) + " bytes whose header claims " +
                   std::to_string(claimed),
               start);
    w.seek(start);
    w.skip(bytes, what);
    return n;
}

// io::DelayedLoadMetadata::readValue: a count, then a mask of count bytes and (unless the size field is
// 0xffffffff) count int64 sizes, each raw or blosc-compressed. It sizes its vectors by the count and by the
// blosc header's uncompressed size (OpenVDB's own files store more sizes than mask entries), so both must
// be what the stored bytes could hold: raw, the bytes themselves; compressed, at most 256 times as many.
void delayedLoad(Walker& w, std::uint32_t numBytes) {
    if (numBytes == 0) return;
    const std::uint64_t end = w.at() + numBytes;
    const auto count = w.get<std::uint32_t>("delayed-load count");
    for (std::uint32_t element : {1u, 8u}) {
        const std::string what = element == 1 ? "delayed-load mask" : "delayed-load sizes";
        const std::uint64_t at = w.at();
        const auto bytes = w.get<std::uint32_t>(what + "' byte count");
        if (element == 8 && bytes == 0xffffffffu) break;
        if (bytes > 0) {
            const std::uint64_t limit = 256 * std::uint64_t(bytes);
            if (bloscUncompressed(w, bytes, what) > limit || std::uint64_t(count) * element > limit)
                w.fail(what + ": " + std::to_string(count) + " entries from " + std::to_string(bytes) + " bytes", at);
        } else {
            w.skip(std::uint64_t(count) * element, what);
        }
    }
    if (w.at() > end) w.fail("delayed-load metadata longer than its " + std::to_string(numBytes) + " bytes", w.at());
    w.seek(end);
}

void metaMap(Walker& w, const std::string& what) {
    const std::uint64_t start = w.at();
    const auto count = w.get<std::uint32_t>(what + " count");
    // Each entry is at least a name length, a type length and a byte count.
    if (std::uint64_t(count) * 12 > w.left()) w.fail(what + " claims " + std::to_string(count) + " entries", start);
    for (std::uint32_t i = 0; i < count; ++i) {
        const std::uint64_t entry = w.at();
        const std::string name = w.string(what + " name");
        const std::string type = w.string(what + " type of '" + name + "'");
        const auto numBytes = w.get<std::uint32_t>(what + " '" + name + "' byte count");
        w.need(numBytes, what + " '" + name + "'");
        const auto fixed = fixedSizes().find(type);
        if (fixed != fixedSizes().end()) {
            if (numBytes != fixed->second)
                w.fail(what + " '" + name + "' of type " + type + " has " + std::to_string(numBytes) + " bytes, not " +
                           std::to_string(fixed->second),
                       entry);
            w.skip(numBytes, what);
        } else if (type == "__delayedload") {
            delayedLoad(w, numBytes);
        } else {
            w.skip(numBytes, what + " '" + name + "'");  // strings, and types OpenVDB reads as unknown bytes
        }
    }
}

/// One grid's descriptor, compression flags, metadata and transform name at the walker's position.
void gridHeader(Walker& w, std::uint32_t version, bool offsets, std::uint64_t fileSize) {
    const std::string name = w.string("grid name");
    w.string("grid type of '" + name + "'");
    if (version >= 216) w.string("instance parent of '" + name + "'");
    const auto gridPos = w.get<std::int64_t>("grid position"), blockPos = w.get<std::int64_t>("block position"),
               endPos = w.get<std::int64_t>("end position");
    // OpenVDB's stream reader reads each grid right after its descriptor, where a file with offsets says
    // it is; the next descriptor follows the grid's tree, which only such a file locates (its end).
    const bool placed = offsets && gridPos > 0;
    if (placed && !(std::uint64_t(gridPos) == w.at() && blockPos >= gridPos && endPos >= blockPos &&
                    std::uint64_t(endPos) <= fileSize))
        w.fail("grid '" + name + "' has offsets that disagree with the file", w.at() - 24);
    if (version >= 222) w.get<std::uint32_t>("compression flags of '" + name + "'");
    metaMap(w, "metadata of grid '" + name + "'");
    w.string("transform type of '" + name + "'");
}

}  // namespace

VdbLayout checkVdbLayout(std::istream& in, std::uint64_t fileSize, const std::filesystem::path& path) {
    Walker w(in, fileSize, path);
    w.seek(0);
    w.get<std::int64_t>("the magic number");
    auto version = w.get<std::uint32_t>("the file version");
    if (version < 211) {
        const auto minor = w.get<std::uint32_t>("the file version");
        version = 100 * version + 10 * minor + w.get<std::uint32_t>("the file version");
    } else {
        w.skip(8, "the library version");
    }
    VdbLayout layout;
    layout.version = version;
    if (version >= 212) layout.offsets = w.get<char>("the grid-offsets flag") != 0;
    if (version >= 220 && version < 222) w.skip(1, "the compression flag");
    w.skip(version >= 218 ? 36 : 16, "the file's UUID");
    metaMap(w, "file metadata");

    const std::uint64_t countAt = w.at();
    const auto grids = w.get<std::int32_t>("the grid count");
    // A descriptor alone is three string lengths and three 64-bit offsets.
    if (grids < 0 || std::uint64_t(grids) * 36 > w.left())
        w.fail("the file claims " + std::to_string(grids) + " grids", countAt);
    // Each grid's header is checked where the stream stands when readVdb reaches it (checkGridHeader).
    in.clear();
    in.seekg(0);
    return layout;
}

void checkGridHeader(std::istream& in, std::uint64_t at, const VdbLayout& layout, std::uint64_t fileSize,
                     const std::filesystem::path& path) {
    Walker w(in, fileSize, path);
    w.seek(at);
    gridHeader(w, layout.version, layout.offsets, fileSize);
    in.clear();
    in.seekg(std::streamoff(at));
}

}  // namespace isoforge::volume::detail
