#pragma once
/// @file Internal to mesh/: reading whole files and a text cursor that knows its line and column,
/// shared by the mesh readers and the Bézier patch reader.

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <concepts>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <type_traits>

#include "core/error.h"

namespace isoforge::mesh::detail {

/// Readers name what they read in their errors; the name is built only when an error happens
/// (a PLY body has millions of values): a string, or a callable that makes one.
inline std::string describe(const char* what) {
    return what;
}
template <class F>
requires std::invocable<const F&> std::string describe(const F& what) {
    return what();
}

inline std::string lowerExtension(const std::filesystem::path& p) {
    std::string e = p.extension().string();
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
    return e;
}

inline std::string readWholeFile(const std::filesystem::path& path, const char* expected = "a mesh file") {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec))
        throw IoError(path.string() + ": is a directory, expected " + std::string(expected));
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError(path.string() + ": cannot open: " + std::strerror(errno));
    std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) throw IoError(path.string() + ": read error");
    return data;
}

// ---------------------------------------------------------------------------------------------
// A cursor over text that knows its line and column, for error messages.
class TextCursor {
public:
    TextCursor(std::string_view text, std::string file, std::size_t offset = 0, std::size_t line = 1)
        : text_(text), file_(std::move(file)), pos_(offset), line_(line), lineStart_(offset) {}

    [[noreturn]] void fail(const std::string& what) const {
        throw IoError(file_ + ":" + std::to_string(line_) + ":" + std::to_string(pos_ - lineStart_ + 1) + ": " + what);
    }
    bool atEnd() const { return pos_ >= text_.size(); }
    void skipSpaces() {  // within the line
        while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\t' || text_[pos_] == '\r')) ++pos_;
    }
    void skipWhitespace() {  // across lines
        while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) {
            if (text_[pos_] == '\n')
                newLine();
            else
                ++pos_;
        }
    }
    bool atLineEnd() {
        skipSpaces();
        return atEnd() || text_[pos_] == '\n' || text_[pos_] == '#';
    }
    void nextLine() {
        while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
        if (pos_ < text_.size()) newLine();
    }
    std::string_view word() {
        skipSpaces();
        std::size_t b = pos_;
        while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
        return text_.substr(b, pos_ - b);
    }
    template <class T>
    T number(const char* what) {
        return number<T>([what] { return std::string(what); });
    }
    template <class T, class What>
    T number(const What& what) {
        skipSpaces();
        if (atEnd() || text_[pos_] == '\n') fail("expected " + describe(what) + ", found end of line");
        const char* b = text_.data() + pos_;
        const char* e = text_.data() + text_.size();
        if (*b == '+') ++b;
        T v{};
        auto [p, ec] = std::from_chars(b, e, v);
        if (ec != std::errc() || (p < e && !std::isspace(static_cast<unsigned char>(*p)) && *p != '/')) {
            const std::size_t at = pos_;  // the error points at the start of the bad word
            const std::string found(word());
            pos_ = at;
            fail("expected " + describe(what) + ", found '" + found + "'");
        }
        if constexpr (std::is_floating_point_v<T>)
            if (!std::isfinite(v)) fail("expected a finite " + describe(what));
        pos_ = static_cast<std::size_t>(p - text_.data());
        return v;
    }
    std::size_t position() const { return pos_; }
    std::size_t line() const { return line_; }
    char peek() const { return atEnd() ? '\0' : text_[pos_]; }
    void advance() { ++pos_; }

private:
    void newLine() {
        ++pos_;
        ++line_;
        lineStart_ = pos_;
    }
    std::string_view text_;
    std::string file_;
    std::size_t pos_, line_, lineStart_;
};

}  // namespace isoforge::mesh::detail
