#include "core/isolate.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <new>

#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include "core/error.h"

namespace isoforge {

namespace {

// The child's answer: one byte for what it is, then the bytes of the result or the error's message.
constexpr char kResult = 'R', kIoError = 'I', kParseError = 'P', kResourceError = 'M', kOther = 'E';

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

[[noreturn]] void answer(int fd, char kind, const std::string& bytes) {
    const bool ok = writeAll(fd, &kind, 1) && writeAll(fd, bytes.data(), bytes.size());
    // _exit: no atexit handlers, static destructors or leak checks of the parent's state in the child.
    ::_exit(ok ? 0 : 3);
}

// The address space the process holds now (with a sanitizer, its shadow reservations too) plus `extra`.
void limitAddressSpace(std::uint64_t extra) {
    std::FILE* f = std::fopen("/proc/self/statm", "r");
    unsigned long long pages = 0;
    if (!f) return;
    const bool ok = std::fscanf(f, "%llu", &pages) == 1;
    std::fclose(f);
    if (!ok) return;
    const rlimit limit{rlim_t(pages * std::uint64_t(::sysconf(_SC_PAGESIZE)) + extra), RLIM_INFINITY};
    ::setrlimit(RLIMIT_AS, &limit);
}

}  // namespace

std::string runIsolated(const std::string& what, const std::string& library, const std::function<std::string()>& work,
                        std::uint64_t memoryLimit) {
    // Two pipes: the answer, and the child's stderr (the library's messages: passed on when it succeeds, its
    // last line quoted when it aborts).
    int out[2], err[2];
    if (::pipe(out) != 0) throw ResourceError(what + ": cannot create a pipe: " + std::strerror(errno));
    if (::pipe(err) != 0) {
        ::close(out[0]);
        ::close(out[1]);
        throw ResourceError(what + ": cannot create a pipe: " + std::strerror(errno));
    }
    const pid_t pid = ::fork();
    if (pid < 0) {
        for (int fd : {out[0], out[1], err[0], err[1]}) ::close(fd);
        throw ResourceError(what + ": cannot start a process to read it: " + std::strerror(errno));
    }
    if (pid == 0) {
        ::close(out[0]);
        ::close(err[0]);
        ::dup2(err[1], STDERR_FILENO);
        ::close(err[1]);
        if (memoryLimit > 0) limitAddressSpace(memoryLimit);
        try {
            answer(out[1], kResult, work());
        } catch (const std::bad_alloc&) {
            answer(out[1], kResourceError,
                   what + ": reading it with " + library + " needed more than the " +
                       std::to_string(memoryLimit >> 20) + " MiB its size justifies (a corrupt length field?)");
        } catch (const ParseError& e) {
            answer(out[1], kParseError, e.what());
        } catch (const IoError& e) {
            answer(out[1], kIoError, e.what());
        } catch (const ResourceError& e) {
            answer(out[1], kResourceError, e.what());
        } catch (const std::exception& e) {
            answer(out[1], kOther, e.what());
        } catch (...) {
            answer(out[1], kOther, "an unknown exception");
        }
    }
    ::close(out[1]);
    ::close(err[1]);
    // Both pipes drained together: a child blocked on a full stderr pipe would never finish its answer.
    std::string reply, messages;
    pollfd fds[2] = {{out[0], POLLIN, 0}, {err[0], POLLIN, 0}};
    std::string* sinks[2] = {&reply, &messages};
    int open = 2;
    char buffer[1 << 16];
    while (open > 0) {
        if (::poll(fds, 2, -1) < 0) {
            if (errno == EINTR) continue;
            break;
        }
        for (int i = 0; i < 2; ++i) {
            if (fds[i].fd < 0 || !(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
            const ssize_t n = ::read(fds[i].fd, buffer, sizeof buffer);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) {
                ::close(fds[i].fd);
                fds[i].fd = -1;
                --open;
            } else {
                sinks[i]->append(buffer, std::size_t(n));
            }
        }
    }
    for (const pollfd& p : fds)
        if (p.fd >= 0) ::close(p.fd);
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
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
    // Passed on with a result; with an error, the error says it (GDCM warns at length about every file of a
    // directory that is not DICOM).
    if (!messages.empty() && !reply.empty() && reply[0] == kResult) std::cerr << messages << std::flush;
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || reply.empty())
        throw IoError(what + ": the process reading it with " + library + " ended without an answer");
    const char kind = reply[0];
    reply.erase(0, 1);
    switch (kind) {
        case kResult:
            return reply;
        case kParseError:
            throw ParseError(reply);
        case kIoError:
            throw IoError(reply);
        case kResourceError:
            throw ResourceError(reply);
        default:
            throw IoError(what + ": " + reply);
    }
}

}  // namespace isoforge
