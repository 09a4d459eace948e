#include "core/isolate.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <new>
#include <utility>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include "core/error.h"

extern char** environ;

namespace isoforge {

namespace {

// The helper's answer on stdout: one byte for what it is, the length of what follows (8 bytes, little-endian),
// then the bytes of the result or the error's message. The length lets runHelper read a volume straight into
// a string of its size (no growing, no copy to drop the first byte: 50 MB for a CT series).
constexpr char kResult = 'R', kIoError = 'I', kParseError = 'P', kResourceError = 'M', kOther = 'E';
constexpr std::size_t kHeader = 9;

bool writeAll(int fd, const char* data, std::size_t size) {
    while (size > 0) {
        const ssize_t n = ::write(fd, data, size);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return false;
        data += n;
        size -= std::size_t(n);
    }
    return true;
}

int answer(char kind, const HelperAnswer& a) {
    std::uint64_t size = a.last.size();
    for (const std::span<const char>& piece : a.first) size += piece.size();
    char header[kHeader] = {kind};
    for (std::size_t i = 0; i < 8; ++i) header[1 + i] = char((size >> (8 * i)) & 0xFF);
    bool ok = writeAll(STDOUT_FILENO, header, kHeader);
    for (const std::span<const char>& piece : a.first) ok = ok && writeAll(STDOUT_FILENO, piece.data(), piece.size());
    return ok && writeAll(STDOUT_FILENO, a.last.data(), a.last.size()) ? 0 : 3;
}

// The answer as it arrives: the header, then the bytes straight into the caller's buffer of the announced
// size (an error's message into a string).
struct Reply {
    explicit Reply(const std::function<char*(std::uint64_t)>& p) : place(p) {}
    const std::function<char*(std::uint64_t)>& place;
    char header[kHeader] = {};
    std::size_t headerBytes = 0;
    std::uint64_t size = 0, bytes = 0;
    char* body = nullptr;
    std::string message;
    std::exception_ptr placeFailed;  // what place() threw; the rest is drained and dropped
    bool tooLong = false;

    char kind() const { return header[0]; }
    bool complete() const { return headerBytes == kHeader && bytes == size && !tooLong && !placeFailed; }

    /// Reads once from fd; false at the end of the stream (or an error).
    bool readFrom(int fd) {
        char scratch[4096];
        char* to = scratch;
        std::size_t room = sizeof scratch;
        if (headerBytes < kHeader) {
            to = header + headerBytes;
            room = kHeader - headerBytes;
        } else if (body && bytes < size) {
            to = body + bytes;
            room = std::size_t(std::min<std::uint64_t>(size - bytes, std::uint64_t(1) << 30));
        }
        const ssize_t n = ::read(fd, to, room);
        if (n < 0 && errno == EINTR) return true;
        if (n <= 0) return false;
        if (headerBytes < kHeader) {
            headerBytes += std::size_t(n);
            if (headerBytes == kHeader) start();
        } else if (to == scratch) {
            tooLong = tooLong || !placeFailed;  // more than announced (or dropped after place() failed)
        } else {
            bytes += std::size_t(n);
        }
        return true;
    }

private:
    void start() {
        for (std::size_t i = 0; i < 8; ++i) size |= std::uint64_t(static_cast<unsigned char>(header[1 + i])) << (8 * i);
        if (size > (std::uint64_t(1) << 40)) {
            tooLong = true;
        } else if (kind() != kResult) {
            message.resize(std::size_t(size));
            body = message.data();
        } else {
            try {
                body = place(size);
            } catch (...) {
                placeFailed = std::current_exception();
            }
        }
    }
};

// The address space the process holds now (with a sanitizer, its shadow reservations too) plus `extra`.
void limitAddressSpace(std::uint64_t extra) {
    std::FILE* f = std::fopen("/proc/self/statm", "r");
    if (!f) return;
    unsigned long long pages = 0;
    const bool ok = std::fscanf(f, "%llu", &pages) == 1;
    std::fclose(f);
    if (!ok) return;
    const rlimit limit{rlim_t(pages * std::uint64_t(::sysconf(_SC_PAGESIZE)) + extra), RLIM_INFINITY};
    ::setrlimit(RLIMIT_AS, &limit);
}

struct Pipe {
    int fd[2] = {-1, -1};
    ~Pipe() {
        for (int f : fd)
            if (f >= 0) ::close(f);
    }
};

}  // namespace

namespace {

int respond(const std::string& what, const std::string& library, std::uint64_t memoryLimit,
            const std::function<HelperAnswer()>& work) {
    try {
        return answer(kResult, work());
    } catch (const std::bad_alloc&) {
        return answer(kResourceError, what + ": reading it with " + library + " needed more than the " +
                                          std::to_string(memoryLimit >> 20) +
                                          " MiB its size justifies (a corrupt length field?)");
    } catch (const ParseError& e) {
        return answer(kParseError, std::string(e.what()));
    } catch (const IoError& e) {
        return answer(kIoError, std::string(e.what()));
    } catch (const ResourceError& e) {
        return answer(kResourceError, std::string(e.what()));
    } catch (const std::exception& e) {
        return answer(kOther, std::string(e.what()));
    }
}

}  // namespace

[[noreturn]] void helperMain(const std::string& what, const std::string& library, std::uint64_t memoryLimit,
                             const std::function<HelperAnswer()>& work) {
    if (memoryLimit > 0) limitAddressSpace(memoryLimit);
    // _exit once answered: a process that lives for one read needs no static destructors (GDCM's), and a
    // sanitizer's leak report at exit would turn a good answer into a failed process.
    ::_exit(respond(what, library, memoryLimit, work));
}

std::string runHelper(const std::string& what, const std::string& library, const std::filesystem::path& program,
                      const std::vector<std::string>& args) {
    std::string body;
    runHelper(what, library, program, args, [&](std::uint64_t size) {
        body.resize(std::size_t(size));
        return body.data();
    });
    return body;
}

std::uint64_t runHelper(const std::string& what, const std::string& library, const std::filesystem::path& program,
                        const std::vector<std::string>& args, const std::function<char*(std::uint64_t)>& place) {
    Pipe out, err;
    if (::pipe2(out.fd, O_CLOEXEC) != 0 || ::pipe2(err.fd, O_CLOEXEC) != 0)
        throw ResourceError(what + ": cannot create a pipe: " + std::strerror(errno));
    // A volume is tens of MB: 1 MiB at a time (the default unprivileged maximum) instead of 64 KiB, 16 times
    // fewer switches between the two processes. Where it is refused, the default stays.
    (void)::fcntl(out.fd[1], F_SETPIPE_SZ, 1 << 20);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_adddup2(&actions, out.fd[1], STDOUT_FILENO);
    posix_spawn_file_actions_adddup2(&actions, err.fd[1], STDERR_FILENO);
    std::vector<std::string> argv0 = {program.string()};
    argv0.insert(argv0.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : argv0) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = 0;
    const int rc = ::posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) throw ResourceError(what + ": cannot start " + program.string() + ": " + std::strerror(rc));
    ::close(out.fd[1]);
    ::close(err.fd[1]);
    out.fd[1] = err.fd[1] = -1;

    // Both pipes drained together: a helper blocked on a full stderr pipe would never finish its answer.
    Reply reply(place);
    std::string messages;
    pollfd fds[2] = {{out.fd[0], POLLIN, 0}, {err.fd[0], POLLIN, 0}};
    int open = 2;
    char buffer[1 << 16];
    while (open > 0) {
        if (::poll(fds, 2, -1) < 0) {
            if (errno == EINTR) continue;
            break;
        }
        if (fds[0].fd >= 0 && (fds[0].revents & (POLLIN | POLLHUP | POLLERR)) && !reply.readFrom(fds[0].fd)) {
            fds[0].fd = -1;
            --open;
        }
        if (fds[1].fd >= 0 && (fds[1].revents & (POLLIN | POLLHUP | POLLERR))) {
            const ssize_t n = ::read(fds[1].fd, buffer, sizeof buffer);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) {
                fds[1].fd = -1;
                --open;
            } else {
                messages.append(buffer, std::size_t(n));
            }
        }
    }
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    if (reply.placeFailed) std::rethrow_exception(reply.placeFailed);
    if (WIFSIGNALED(status)) {
        const int sig = WTERMSIG(status);
        const char* name = ::strsignal(sig);
        // The library's last words (an assertion's text), on the same line.
        while (!messages.empty() && (messages.back() == '\n' || messages.back() == ' ')) messages.pop_back();
        const std::size_t line = messages.rfind('\n');
        const std::string last = line == std::string::npos ? messages : messages.substr(line + 1);
        throw IoError(what + ": " + library + " stopped the reading process (signal " + std::to_string(sig) + ": " +
                      (name ? name : "?") + "); the file is corrupt or of a kind " + library + " does not expect" +
                      (last.empty() ? "" : " (" + last + ")"));
    }
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || !reply.complete()) {
        const std::size_t line = messages.find('\n');
        throw IoError(what + ": the process reading it with " + library + " (" + program.filename().string() +
                      ") ended without an answer" +
                      (messages.empty() ? std::string() : ": " + messages.substr(0, line)));
    }
    // Passed on with a result; with an error, the error says it (GDCM warns at length about every file of a
    // directory that is not DICOM).
    const char kind = reply.kind();
    if (!messages.empty() && kind == kResult) std::cerr << messages << std::flush;
    switch (kind) {
        case kResult:
            return reply.size;
        case kParseError:
            throw ParseError(reply.message);
        case kIoError:
            throw IoError(reply.message);
        case kResourceError:
            throw ResourceError(reply.message);
        default:
            throw IoError(what + ": " + reply.message);
    }
}

}  // namespace isoforge
