#pragma once
/// @file Numbers from a file, written in messages as they read back.

#include <charconv>
#include <string>

namespace isoforge {

/// The shortest text that reads back as `v` (5, 2.5, 3.3333333333333334e+78, -3e+58, nan): for error
/// messages naming a value read from a file, whatever its size (no conversion to an integer first).
inline std::string numberText(double v) {
    char buf[32];
    const auto end = std::to_chars(buf, buf + sizeof buf, v).ptr;
    return std::string(buf, end);
}

}  // namespace isoforge
