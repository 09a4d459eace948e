#include "volume/dicom_layout.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <optional>
#include <string>

#include "core/error.h"

namespace isoforge::volume::detail {

namespace {

constexpr std::uint32_t kUndefined = 0xFFFFFFFFu;
constexpr int kMaxDepth = 64;

bool upper(unsigned char c) {
    return c >= 'A' && c <= 'Z';
}

bool isVr(const unsigned char* vr, const char* name) {
    return vr[0] == name[0] && vr[1] == name[1];
}

// VRs whose explicit-VR header has two reserved bytes and a 32-bit length (PS3.5 7.1.2).
bool longLength(const unsigned char* vr) {
    for (const char* k : {"OB", "OD", "OF", "OL", "OV", "OW", "SQ", "SV", "UC", "UN", "UR", "UT", "UV"})
        if (isVr(vr, k)) return true;
    return false;
}

std::string tagName(std::uint32_t group, std::uint32_t element) {
    char s[16];
    std::snprintf(s, sizeof s, "(%04X,%04X)", group, element);
    return s;
}

/// Reads headers at byte offsets and walks elements and items; a std::nullopt result means "not understood
/// here": the caller stops checking (GDCM decides).
class Walk {
public:
    explicit Walk(const std::filesystem::path& file) : file_(file), in_(file, std::ios::binary) {
        std::error_code ec;
        size_ = std::filesystem::file_size(file, ec);
        if (!in_ || ec) size_ = 0;
    }

    std::uint64_t size() const { return size_; }

    /// Reads n <= 12 bytes at `at` into head; false past the end of the file.
    bool read(std::uint64_t at, std::size_t n) {
        if (at > size_ || n > size_ - at) return false;
        in_.clear();
        in_.seekg(std::streamoff(at));
        return bool(in_.read(reinterpret_cast<char*>(head_), std::streamsize(n)));
    }

    /// n bytes at `at` as a string; nothing past the end of the file.
    std::optional<std::string> bytes(std::uint64_t at, std::uint32_t n) {
        if (at > size_ || n > size_ - at) return std::nullopt;
        std::string s(n, '\0');
        in_.clear();
        in_.seekg(std::streamoff(at));
        if (!in_.read(s.data(), std::streamsize(n))) return std::nullopt;
        return s;
    }

    std::uint32_t number(std::size_t offset, int bytes) const {
        std::uint32_t v = 0;
        for (int i = 0; i < bytes; ++i) v = (v << 8) | head_[offset + std::size_t(big_ ? i : bytes - 1 - i)];
        return v;
    }

    void syntax(bool explicitVr, bool big) {
        explicit_ = explicitVr;
        big_ = big;
    }

    [[noreturn]] void fail(std::uint32_t group, std::uint32_t element, std::uint64_t at,
                           const std::string& what) const {
        throw IoError(file_.string() + ": DICOM element " + tagName(group, element) + " at byte " + std::to_string(at) +
                      " " + what);
    }

    struct Element {
        std::uint32_t group = 0, element = 0, length = 0;
        std::uint64_t header = 8;  ///< bytes of tag, VR and length
        bool wide = false;         ///< explicit VR with a 32-bit length
    };
    /// The element whose header read() put in head_, `left` bytes before the end of its container; nothing
    /// when the VR of an explicit VR element is not two capitals (not understood here).
    std::optional<Element> header(std::uint64_t at, std::uint64_t left, const char* container) const {
        Element e;
        e.group = number(0, 2);
        e.element = number(2, 2);
        e.wide = explicit_ && longLength(head_ + 4);
        e.header = e.wide ? 12 : 8;
        if (left < e.header) fail(e.group, e.element, at, std::string("is cut by the end of its ") + container);
        if (explicit_ && (!upper(head_[4]) || !upper(head_[5]))) return std::nullopt;
        e.length = !explicit_ ? number(4, 4) : e.wide ? number(8, 4) : number(6, 2);
        return e;
    }
    /// Fails unless the element's value fits in the `left` bytes of its container.
    void fits(const Element& e, std::uint64_t at, std::uint64_t left, const char* container) const {
        if (e.length > left - e.header)
            fail(e.group, e.element, at,
                 "claims " + std::to_string(e.length) + " bytes; its " + container + " has " +
                     std::to_string(left - e.header) + " after the element's header");
    }

    /// Data elements from `at` to `end`, or to an item delimiter when `delimited`; returns where they end.
    std::optional<std::uint64_t> elements(std::uint64_t at, std::uint64_t end, bool delimited, int depth,
                                          const char* container) {
        if (depth > kMaxDepth) return std::nullopt;
        while (at < end) {
            if (!read(at, std::min<std::uint64_t>(end - at, 12)) || end - at < 4)
                fail(0, 0, at, std::string("is cut by the end of its ") + container);
            const std::uint32_t group = number(0, 2), element = number(2, 2);
            if (group == 0xFFFE) {  // only an item's delimiter belongs here
                if (!delimited || element != 0xE00D || end - at < 8) return std::nullopt;
                return at + 8;
            }
            const auto e = header(at, end - at, container);
            if (!e) return std::nullopt;
            const bool sequence = explicit_ && isVr(head_ + 4, "SQ");
            const bool pixels = group == 0x7FE0 && element == 0x0010;
            if (e->wide && e->length == kUndefined) {
                // A sequence or encapsulated pixel data: items up to a delimiter. UN of undefined length is a
                // sequence whose items are implicit VR little endian whatever the transfer syntax (PS3.5 6.2.2;
                // what a converter writes for an implicit file's sequences it has no dictionary entry for).
                const bool unknown = isVr(head_ + 4, "UN");
                if (!sequence && !pixels && !unknown) return std::nullopt;
                const bool wasExplicit = explicit_, wasBig = big_;
                if (unknown) syntax(false, false);
                const auto next = items(at + e->header, end, true, depth + 1, pixels);
                syntax(wasExplicit, wasBig);
                if (!next) return std::nullopt;
                at = *next;
                continue;
            }
            if (!explicit_ && e->length == kUndefined) {  // implicit VR: a sequence
                const auto next = items(at + e->header, end, true, depth + 1, false);
                if (!next) return std::nullopt;
                at = *next;
                continue;
            }
            fits(*e, at, end - at, container);
            // A defined-length sequence: its items are checked; one not understood ends there, not here.
            if (sequence) (void)items(at + e->header, at + e->header + e->length, false, depth + 1, false);
            at += e->header + e->length;
        }
        if (delimited) return std::nullopt;  // no delimiter before the end: GDCM's to judge
        return at;
    }

    /// Items (or pixel data fragments) from `at` to `end`, or to a sequence delimiter when `delimited`.
    std::optional<std::uint64_t> items(std::uint64_t at, std::uint64_t end, bool delimited, int depth, bool fragments) {
        if (depth > kMaxDepth) return std::nullopt;
        while (at < end) {
            if (end - at < 8 || !read(at, 8)) fail(0xFFFE, 0xE000, at, "is cut by the end of its sequence");
            const std::uint32_t group = number(0, 2), element = number(2, 2), length = number(4, 4);
            if (group == 0xFFFE && element == 0xE0DD) return delimited ? std::optional(at + 8) : std::nullopt;
            if (group != 0xFFFE || element != 0xE000) return std::nullopt;
            if (length == kUndefined) {
                if (fragments) return std::nullopt;
                const auto next = elements(at + 8, end, true, depth + 1, "item");
                if (!next) return std::nullopt;
                at = *next;
                continue;
            }
            if (length > end - at - 8)
                fail(group, element, at,
                     "(an item) claims " + std::to_string(length) + " bytes; its sequence has " +
                         std::to_string(end - at - 8) + " after the item's header");
            if (!fragments) (void)elements(at + 8, at + 8 + length, false, depth + 1, "item");
            at += 8 + length;
        }
        if (delimited) return std::nullopt;
        return at;
    }

private:
    std::filesystem::path file_;
    std::ifstream in_;
    std::uint64_t size_ = 0;
    unsigned char head_[12] = {};
    bool explicit_ = true, big_ = false;
};

}  // namespace

void checkDicomLayout(const std::filesystem::path& file) {
    Walk w(file);
    if (w.size() < 132 || w.bytes(128, 4) != "DICM") return;
    // The file meta group: explicit VR little endian. GDCM reads as far as the group length (0002,0000) says,
    // whatever the groups it meets on the way.
    std::uint64_t at = 132, groupEnd = 0;
    std::string syntax;
    while (at < w.size()) {
        const std::uint64_t left = w.size() - at;
        if (!w.read(at, std::min<std::uint64_t>(left, 12))) return;
        const std::uint32_t group = left >= 2 ? w.number(0, 2) : 0, element = left >= 4 ? w.number(2, 2) : 0;
        if (group != 0x0002 && at >= groupEnd) break;  // the data set begins
        if (left < 8) w.fail(group, element, at, "is cut by the end of the file");
        const auto e = w.header(at, left, "file");
        if (!e) return;                                  // not explicit VR: GDCM has ways with old files
        if (e->wide && e->length == kUndefined) return;  // undefined length in the meta group: GDCM's to read
        w.fits(*e, at, left, "file");
        if (group == 0x0002 && element == 0x0000 && e->length == 4 && !e->wide && w.read(at + 8, 4))
            groupEnd = at + 12 + w.number(0, 4);
        if (group == 0x0002 && element == 0x0010 && e->length <= 64) {  // the transfer syntax UID
            auto uid = w.bytes(at + e->header, e->length);
            if (!uid) return;
            while (!uid->empty() && (uid->back() == '\0' || uid->back() == ' ')) uid->pop_back();
            syntax = *uid;
        }
        at += e->header + e->length;
    }
    if (syntax == "1.2.840.10008.1.2.1.99") return;  // deflated: GDCM inflates it
    w.syntax(syntax != "1.2.840.10008.1.2", syntax == "1.2.840.10008.1.2.2");
    (void)w.elements(at, w.size(), false, 0, "file");
}

}  // namespace isoforge::volume::detail
