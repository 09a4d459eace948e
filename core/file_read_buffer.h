// A read-only std::streambuf over a file whose position is kept in memory: tellg() and seeks within its
// buffer make no system call.
//
// std::ifstream's filebuf asks the kernel for the position on every tellg() and drops its 8 KiB buffer on
// every seekg(). OpenVDB's LeafNode::readBuffers calls tellg() for each leaf and seeks over each leaf's
// mask, so a 43 MiB level set read through an ifstream made 195,000 lseek calls and read 536 MB in 8 KiB
// pieces (docs/performance.md, issue #18).
#pragma once

#include <cstdint>
#include <filesystem>
#include <streambuf>
#include <vector>

namespace isoforge {

class FileReadBuffer : public std::streambuf {
public:
    /// Opens `path` for reading; isOpen() says whether it could.
    explicit FileReadBuffer(const std::filesystem::path& path, std::size_t bufferBytes = std::size_t(1) << 20);
    ~FileReadBuffer() override;
    FileReadBuffer(const FileReadBuffer&) = delete;
    FileReadBuffer& operator=(const FileReadBuffer&) = delete;

    bool isOpen() const { return fd_ >= 0; }
    /// The errno of a failed read (0 if none): the stream sees only its end.
    int readError() const { return error_; }

protected:
    int_type underflow() override;
    std::streamsize xsgetn(char* to, std::streamsize n) override;
    pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode which) override;
    pos_type seekpos(pos_type pos, std::ios_base::openmode which) override;

private:
    std::uint64_t position() const { return start_ + std::uint64_t(gptr() - eback()); }
    /// Reads up to n bytes at `at` (retrying short reads and EINTR); fewer at the end of the file or an error.
    std::size_t readAt(char* to, std::size_t n, std::uint64_t at);

    int fd_ = -1;
    int error_ = 0;
    std::vector<char> buffer_;
    std::uint64_t start_ = 0;  // the file offset of eback()
};

}  // namespace isoforge
