#include "core/atomic_file.h"

#include <sys/stat.h>
#include <unistd.h>
#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "core/error.h"
#include "core/temporary_files.h"

namespace isoforge {

AtomicFile::AtomicFile(std::filesystem::path target) : target_(std::move(target)) {
    std::filesystem::path dir = target_.parent_path();
    if (dir.empty()) dir = ".";
    std::string pattern = (dir / ("." + target_.filename().string() + ".tmp.XXXXXX")).string();
    int fd = ::mkstemp(pattern.data());
    if (fd < 0)
        throw IoError(target_.string() + ": cannot create a file in '" + dir.string() + "': " + std::strerror(errno));
    ::fchmod(fd, 0644);
    temp_ = pattern;
    signalSlot_ = removeOnSignal(pattern);
    file_ = ::fdopen(fd, "wb");
    if (!file_) {
        ::close(fd);
        std::filesystem::remove(temp_);
        forgetTemporary(signalSlot_);
        throw IoError(target_.string() + ": cannot open temporary file: " + std::strerror(errno));
    }
    std::setvbuf(file_, nullptr, _IOFBF, 1 << 20);
}

AtomicFile::~AtomicFile() {
    if (file_) std::fclose(file_);
    if (!committed_) {
        std::error_code ec;
        std::filesystem::remove(temp_, ec);
    }
    forgetTemporary(signalSlot_);
}

void AtomicFile::write(const void* data, std::size_t bytes) {
    if (bytes && std::fwrite(data, 1, bytes, file_) != bytes)
        throw IoError(target_.string() + ": write failed: " + std::strerror(errno));
}

void AtomicFile::commit() {
    bool ok = std::fflush(file_) == 0 && !std::ferror(file_);
    int err = errno;
    ok = (std::fclose(file_) == 0) && ok;
    file_ = nullptr;
    if (!ok) throw IoError(target_.string() + ": write failed: " + std::strerror(err));
    std::error_code ec;
    std::filesystem::rename(temp_, target_, ec);
    if (!ec) {
        forgetTemporary(signalSlot_);
        signalSlot_ = -1;
    }
    if (ec) throw IoError(target_.string() + ": cannot rename temporary file onto it: " + ec.message());
    committed_ = true;
}

}  // namespace isoforge
