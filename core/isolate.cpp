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

/// Runs `run` (which writes the answer or the parts) and turns what it throws into an error answer.
int respond(const std::string& what, const std::string& library, std::uint64_t memoryLimit,
            const std::function<int()>& run) {
    try {
        return run();
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

/// The reader gone (it stopped reading: destroyed early): nothing more to write.
struct ReaderGone {};

}  // namespace

[[noreturn]] void helperMain(const std::string& what, const std::string& library, std::uint64_t memoryLimit,
                             const std::function<HelperAnswer()>& work) {
    if (memoryLimit > 0) limitAddressSpace(memoryLimit);
    // _exit once answered: a process that lives for one read needs no static destructors (GDCM's), and a
    // sanitizer's leak report at exit would turn a good answer into a failed process.
    ::_exit(respond(what, library, memoryLimit, [&] { return answer(kResult, work()); }));
}

[[noreturn]] void helperStreamMain(const std::string& what, const std::string& library, std::uint64_t memoryLimit,
                                   const std::function<void(const HelperSend&)>& work) {
    if (memoryLimit > 0) limitAddressSpace(memoryLimit);
    ::signal(SIGPIPE, SIG_IGN);  // a reader that stops reading is a failed write, not a signal
    int rc = 0;
    try {
        rc = respond(what, library, memoryLimit, [&] {
            work([](const HelperAnswer& a) {
                if (answer(kResult, a) != 0) throw ReaderGone{};
            });
            return 0;
        });
    } catch (const ReaderGone&) {
        rc = 3;
    }
    ::_exit(rc);
}

struct HelperStream::State {
    std::string what, library;
    std::filesystem::path program;
    Pipe out, err;
    pid_t pid = -1;
    std::string messages;  // the helper's stderr so far
    bool outOpen = true, errOpen = true;
    std::exception_ptr placeFailed;
    bool tooMuch = false;  // bytes after the last part

    /// Reads stderr (and stdout into `reply`, while it is not done) until `done()` or both are closed.
    template <class Done>
    void pump(Reply* reply, Done&& done) {
        char buffer[1 << 16];
        while ((outOpen || errOpen) && !done()) {
            pollfd fds[2] = {{outOpen ? out.fd[0] : -1, POLLIN, 0}, {errOpen ? err.fd[0] : -1, POLLIN, 0}};
            if (::poll(fds, 2, -1) < 0) {
                if (errno == EINTR) continue;
                break;
            }
            if (fds[0].fd >= 0 && (fds[0].revents & (POLLIN | POLLHUP | POLLERR))) {
                if (reply) {
                    if (!reply->readFrom(out.fd[0])) outOpen = false;
                } else {  // past the last part: anything more is too much
                    const ssize_t n = ::read(out.fd[0], buffer, sizeof buffer);
                    if (n < 0 && errno == EINTR) continue;
                    if (n <= 0)
                        outOpen = false;
                    else
                        tooMuch = true;
                }
            }
            if (fds[1].fd >= 0 && (fds[1].revents & (POLLIN | POLLHUP | POLLERR))) {
                const ssize_t n = ::read(err.fd[0], buffer, sizeof buffer);
                if (n < 0 && errno == EINTR) continue;
                if (n <= 0)
                    errOpen = false;
                else
                    messages.append(buffer, std::size_t(n));
            }
        }
    }

    /// Drains both pipes to their ends and waits for the helper; throws if it did not end well.
    void end(bool answered) {
        pump(nullptr, [] { return false; });
        int status = 0;
        while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
        }
        pid = -1;
        if (placeFailed) std::rethrow_exception(placeFailed);
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
        if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || !answered || tooMuch) {
            const std::size_t line = messages.find('\n');
            throw IoError(what + ": the process reading it with " + library + " (" + program.filename().string() +
                          ") ended without an answer" +
                          (messages.empty() ? std::string() : ": " + messages.substr(0, line)));
        }
    }
};

HelperStream::HelperStream(const std::string& what, const std::string& library, const std::filesystem::path& program,
                           const std::vector<std::string>& args)
    : s_(std::make_unique<State>()) {
    s_->what = what;
    s_->library = library;
    s_->program = program;
    Pipe& out = s_->out;
    Pipe& err = s_->err;
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
    const int rc = ::posix_spawn(&s_->pid, program.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) {
        s_->pid = -1;
        throw ResourceError(what + ": cannot start " + program.string() + ": " + std::strerror(rc));
    }
    ::close(out.fd[1]);
    ::close(err.fd[1]);
    out.fd[1] = err.fd[1] = -1;
}

HelperStream::~HelperStream() {
    if (s_->pid > 0) {  // not finished: nobody wants the rest
        ::kill(s_->pid, SIGKILL);
        while (::waitpid(s_->pid, nullptr, 0) < 0 && errno == EINTR) {
        }
    }
}

std::uint64_t HelperStream::next(const std::function<char*(std::uint64_t)>& place) {
    State& s = *s_;
    if (s.pid < 0) throw IoError(s.what + ": the reading process has ended");
    // Both pipes drained together: a helper blocked on a full stderr pipe would never finish its part.
    Reply reply(place);
    const auto done = [&] { return reply.complete() || reply.tooLong; };
    s.pump(&reply, done);
    if (reply.placeFailed) s.placeFailed = reply.placeFailed;
    if (!reply.complete()) {
        s.end(false);  // throws: why it ended without the part
        throw IoError(s.what + ": the process reading it with " + s.library + " ended without an answer");
    }
    switch (reply.kind()) {
        case kResult:
            return reply.size;
        case kParseError:
            s.end(true);
            throw ParseError(reply.message);
        case kIoError:
            s.end(true);
            throw IoError(reply.message);
        case kResourceError:
            s.end(true);
            throw ResourceError(reply.message);
        default:
            s.end(true);
            throw IoError(s.what + ": " + reply.message);
    }
}

void HelperStream::finish() {
    State& s = *s_;
    if (s.pid < 0) return;
    s.end(true);
    // Passed on with a result; with an error, the error says it (GDCM warns at length about every file of a
    // directory that is not DICOM).
    if (!s.messages.empty()) std::cerr << s.messages << std::flush;
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
    HelperStream helper(what, library, program, args);
    const std::uint64_t size = helper.next(place);
    helper.finish();
    return size;
}

}  // namespace isoforge
