#include "core/scratch_file.h"

#include <unistd.h>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <string>

#include "core/error.h"

namespace isoforge {

ScratchFile::ScratchFile(const std::filesystem::path& nextTo) : nextTo_(nextTo) {
    std::filesystem::path dir = nextTo.parent_path();
    if (dir.empty()) dir = ".";
    std::string pattern = (dir / ("." + nextTo.filename().string() + ".scratch.XXXXXX")).string();
    const int fd = ::mkstemp(pattern.data());
    if (fd < 0)
        throw IoError(nextTo.string() + ": cannot create a scratch file in '" + dir.string() +
                      "': " + std::strerror(errno));
    ::unlink(pattern.c_str());
    file_ = ::fdopen(fd, "w+b");
    if (!file_) {
        ::close(fd);
        throw IoError(nextTo.string() + ": cannot open a scratch file: " + std::strerror(errno));
    }
    std::setvbuf(file_, nullptr, _IOFBF, 1 << 20);
}

ScratchFile::~ScratchFile() {
    if (file_) std::fclose(file_);
}

void ScratchFile::write(const void* data, std::size_t bytes) {
    if (bytes && std::fwrite(data, 1, bytes, file_) != bytes)
        throw IoError(nextTo_.string() + ": scratch write failed (disk full?): " + std::strerror(errno));
    size_ += bytes;
}

void ScratchFile::rewind() {
    if (std::fflush(file_) != 0 || std::fseek(file_, 0, SEEK_SET) != 0)
        throw IoError(nextTo_.string() + ": scratch file: " + std::strerror(errno));
}

std::size_t ScratchFile::read(void* data, std::size_t bytes) {
    const std::size_t n = std::fread(data, 1, bytes, file_);
    if (n < bytes && std::ferror(file_))
        throw IoError(nextTo_.string() + ": scratch read failed: " + std::strerror(errno));
    return n;
}

}  // namespace isoforge
