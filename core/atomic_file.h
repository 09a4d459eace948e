#pragma once
/// @file Atomic output files: write to a temporary file beside the target, then rename.
/// A reader of the target never sees a partial file, and a failed write leaves no file behind, nor does
/// a process stopped by SIGINT, SIGTERM or SIGHUP (core/temporary_files.h).

#include <cstdio>
#include <filesystem>
#include <string>
#include <string_view>

namespace isoforge {

class AtomicFile {
public:
    /// Creates a temporary file in the directory of `target`.
    /// @throw IoError if the directory is not writable.
    explicit AtomicFile(std::filesystem::path target);
    ~AtomicFile();  ///< removes the temporary file unless commit() succeeded
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    /// The stream to write to (buffered).
    std::FILE* stream() const { return file_; }
    void write(const void* data, std::size_t bytes);
    void write(std::string_view text) { write(text.data(), text.size()); }

    /// Flushes, closes and renames the temporary file onto the target.
    /// @throw IoError on any write error (disk full, ...); the target is then untouched.
    void commit();

    const std::filesystem::path& target() const { return target_; }
    const std::filesystem::path& temporaryPath() const { return temp_; }

private:
    std::filesystem::path target_;
    std::filesystem::path temp_;
    std::FILE* file_ = nullptr;
    bool committed_ = false;
    int signalSlot_ = -1;
};

}  // namespace isoforge
