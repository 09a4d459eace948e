#pragma once
/// @file Numbers from a file, written in messages as they read back.

#include <charconv>
#include <cstdio>
#include <string>

namespace isoforge {

/// The shortest text that reads back as `v` (5, 2.5, 3.3333333333333334e+78, -3e+58, nan): for error
/// messages naming a value read from a file, whatever its size (no conversion to an integer first).
inline std::string numberText(double v) {
    char buf[32];
    const auto end = std::to_chars(buf, buf + sizeof buf, v).ptr;
    return std::string(buf, end);
}

/// "1,234,567": counts in summaries.
inline std::string countText(unsigned long long n) {
    const std::string digits = std::to_string(n);
    std::string s;
    for (std::size_t i = 0; i < digits.size(); ++i) {
        if (i > 0 && (digits.size() - i) % 3 == 0) s.push_back(',');
        s.push_back(digits[i]);
    }
    return s;
}

/// A size in messages: "512 bytes", "3.2 MiB", "394 TiB" (three significant digits, powers of 1024).
inline std::string bytesText(double b) {
    const char* units[] = {"bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    int u = 0;
    while (b >= 1024 && u < 6) {
        b /= 1024;
        ++u;
    }
    char buf[48];
    std::snprintf(buf, sizeof buf, "%.*g %s", b < 10 ? 2 : 3, b, units[u]);
    return buf;
}

}  // namespace isoforge
