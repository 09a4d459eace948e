#pragma once
/// @file The little JSON the page is sent (summaries, events): an object written field by field.

#include <cmath>
#include <cstdio>
#include <string>
#include <string_view>

namespace isoforge::view {

/// `s` as a JSON string literal, quotes included.
inline std::string jsonString(std::string_view s) {
    std::string out = "\"";
    for (const char c : s) {
        const auto u = static_cast<unsigned char>(c);
        if (c == '"' || c == '\\') {
            out += '\\';
            out += c;
        } else if (c == '\n') {
            out += "\\n";
        } else if (c == '\t') {
            out += "\\t";
        } else if (u < 0x20) {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\u%04x", u);
            out += buf;
        } else {
            out += c;
        }
    }
    return out + "\"";
}

/// A number as JSON (non-finite values as null, which JSON has no other way to say).
inline std::string jsonNumber(double v) {
    if (!std::isfinite(v)) return "null";
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9g", v);
    return buf;
}

/// {"a": 1, "b": "x"} built in order: add(key, rawJson).
class JsonObject {
public:
    JsonObject& raw(std::string_view key, const std::string& json) {
        text_ += (text_.empty() ? "{" : ",") + jsonString(key) + ":" + json;
        return *this;
    }
    JsonObject& str(std::string_view key, std::string_view v) { return raw(key, jsonString(v)); }
    JsonObject& num(std::string_view key, double v) { return raw(key, jsonNumber(v)); }
    JsonObject& flag(std::string_view key, bool v) { return raw(key, v ? "true" : "false"); }
    std::string text() const { return text_.empty() ? "{}" : text_ + "}"; }

private:
    std::string text_;
};

}  // namespace isoforge::view
