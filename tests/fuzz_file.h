#pragma once
/// @file For the libFuzzer targets of file readers: each input is written to a scratch file of this
/// process (the readers take paths, as the command line gives them), named with the extension the reader
/// dispatches on.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

#include <unistd.h>

namespace isoforge::fuzz {

/// Writes data to the file `p` (a failure here is the harness's, so it traps).
inline void writeFile(const std::filesystem::path& p, const std::uint8_t* data, std::size_t size) {
    std::FILE* f = std::fopen(p.c_str(), "wb");
    if (!f) __builtin_trap();
    if (size && std::fwrite(data, 1, size, f) != size) __builtin_trap();
    std::fclose(f);
}

/// Writes data to <tmp>/isoforge-fuzz-<pid><extension> and returns that path.
inline std::filesystem::path scratchFile(const std::uint8_t* data, std::size_t size, const std::string& extension) {
    const std::filesystem::path p =
        std::filesystem::temp_directory_path() / ("isoforge-fuzz-" + std::to_string(::getpid()) + extension);
    writeFile(p, data, size);
    return p;
}

}  // namespace isoforge::fuzz
