#pragma once
/// @file An anonymous scratch file for data too large to hold in memory: created beside an output (on
/// the same disk, where the output will need the room anyway) and unlinked at once, so that nothing is
/// left behind whatever happens to the process.

#include <cstdint>
#include <cstdio>
#include <filesystem>

namespace isoforge {

class ScratchFile {
public:
    /// @throw IoError if no file can be created in the directory of `nextTo`.
    explicit ScratchFile(const std::filesystem::path& nextTo);
    ~ScratchFile();
    ScratchFile(const ScratchFile&) = delete;
    ScratchFile& operator=(const ScratchFile&) = delete;

    /// Appends; @throw IoError on a failed write (disk full).
    void write(const void* data, std::size_t bytes);
    /// Goes back to the start for reading what was written.
    void rewind();
    /// Reads up to `bytes`; returns how many were read (0 at the end). @throw IoError on a read error.
    std::size_t read(void* data, std::size_t bytes);
    std::uint64_t size() const { return size_; }

private:
    std::filesystem::path nextTo_;
    std::FILE* file_ = nullptr;
    std::uint64_t size_ = 0;
};

}  // namespace isoforge
