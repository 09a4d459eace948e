#include "core/file_read_buffer.h"

#include <cerrno>
#include <cstring>

#include <fcntl.h>
#include <unistd.h>

namespace isoforge {

FileReadBuffer::FileReadBuffer(const std::filesystem::path& path, std::size_t bufferBytes)
    : fd_(::open(path.c_str(), O_RDONLY | O_CLOEXEC)), buffer_(bufferBytes) {
    setg(buffer_.data(), buffer_.data(), buffer_.data());
}

FileReadBuffer::~FileReadBuffer() {
    if (fd_ >= 0) ::close(fd_);
}

std::size_t FileReadBuffer::readAt(char* to, std::size_t n, std::uint64_t at) {
    std::size_t got = 0;
    while (got < n && fd_ >= 0) {
        const ssize_t r = ::pread(fd_, to + got, n - got, off_t(at + got));
        if (r < 0 && errno == EINTR) continue;
        if (r < 0) error_ = errno;
        if (r <= 0) break;
        got += std::size_t(r);
    }
    return got;
}

FileReadBuffer::int_type FileReadBuffer::underflow() {
    if (gptr() < egptr()) return traits_type::to_int_type(*gptr());
    start_ = position();
    const std::size_t got = readAt(buffer_.data(), buffer_.size(), start_);
    setg(buffer_.data(), buffer_.data(), buffer_.data() + got);
    return got ? traits_type::to_int_type(*gptr()) : traits_type::eof();
}

std::streamsize FileReadBuffer::xsgetn(char* to, std::streamsize n) {
    if (n <= 0) return 0;  // OpenVDB reads empty strings into null pointers
    // What the buffer holds, then a large rest straight from the file (a buffer's worth or more).
    const std::streamsize held = std::min<std::streamsize>(n, egptr() - gptr());
    std::memcpy(to, gptr(), std::size_t(held));
    gbump(int(held));
    std::streamsize done = held;
    if (n - done >= std::streamsize(buffer_.size())) {
        const std::uint64_t at = position();
        const std::size_t got = readAt(to + done, std::size_t(n - done), at);
        start_ = at + got;
        setg(buffer_.data(), buffer_.data(), buffer_.data());
        return done + std::streamsize(got);
    }
    while (done < n && underflow() != traits_type::eof()) {
        const std::streamsize take = std::min<std::streamsize>(n - done, egptr() - gptr());
        std::memcpy(to + done, gptr(), std::size_t(take));
        gbump(int(take));
        done += take;
    }
    return done;
}

FileReadBuffer::pos_type FileReadBuffer::seekoff(off_type off, std::ios_base::seekdir dir,
                                                 std::ios_base::openmode which) {
    std::int64_t base = 0;
    if (dir == std::ios_base::cur) {
        base = std::int64_t(position());
    } else if (dir == std::ios_base::end) {
        const off_t end = fd_ >= 0 ? ::lseek(fd_, 0, SEEK_END) : -1;
        if (end < 0) return pos_type(off_type(-1));
        base = std::int64_t(end);
    }
    if (off == 0 && dir == std::ios_base::cur) return pos_type(off_type(base));  // tellg(): no system call
    return seekpos(pos_type(off_type(base + off)), which);
}

FileReadBuffer::pos_type FileReadBuffer::seekpos(pos_type pos, std::ios_base::openmode which) {
    if (!(which & std::ios_base::in) || off_type(pos) < 0) return pos_type(off_type(-1));
    const std::uint64_t to = std::uint64_t(off_type(pos));
    const std::uint64_t held = std::uint64_t(egptr() - eback());
    if (to >= start_ && to <= start_ + held) {
        setg(eback(), eback() + (to - start_), egptr());  // within the buffer
    } else {
        start_ = to;
        setg(buffer_.data(), buffer_.data(), buffer_.data());
    }
    return pos;
}

}  // namespace isoforge
