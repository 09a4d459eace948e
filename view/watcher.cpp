#include "view/watcher.h"

#include <poll.h>
#include <sys/eventfd.h>
#include <sys/inotify.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>

#include "core/error.h"

namespace isoforge::view {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct FileWatcher::State {
    int inotify = -1, wake = -1;
    std::map<int, fs::path> dirs;  ///< watch descriptor -> directory
    std::set<fs::path> files;      ///< absolute, normalized
};

namespace {

// What a save looks like to a directory: written in place (modify, close), renamed over (moved to),
// created, deleted or renamed away (an editor's backup).
constexpr std::uint32_t kEvents = IN_CLOSE_WRITE | IN_MODIFY | IN_MOVED_TO | IN_MOVED_FROM | IN_CREATE | IN_DELETE;

fs::path absoluteOf(const std::string& file) {
    std::error_code ec;
    fs::path p = fs::absolute(file, ec);
    if (ec) p = file;
    return p.lexically_normal();
}

}  // namespace

FileWatcher::FileWatcher() : s_(new State) {
    s_->inotify = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    s_->wake = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (s_->inotify < 0 || s_->wake < 0) {
        const std::string why = std::strerror(errno);
        if (s_->inotify >= 0) close(s_->inotify);
        if (s_->wake >= 0) close(s_->wake);
        delete s_;
        throw IoError("cannot watch files (inotify): " + why);
    }
}

FileWatcher::~FileWatcher() {
    close(s_->inotify);
    close(s_->wake);
    delete s_;
}

void FileWatcher::watch(const std::vector<std::string>& files) {
    std::set<fs::path> wanted, dirs;
    for (const std::string& f : files) {
        wanted.insert(absoluteOf(f));
        dirs.insert(absoluteOf(f).parent_path());
    }
    // Directories kept stay watched throughout, so that no event of theirs is lost in between.
    for (auto it = s_->dirs.begin(); it != s_->dirs.end();)
        if (dirs.count(it->second)) {
            ++it;
        } else {
            inotify_rm_watch(s_->inotify, it->first);
            it = s_->dirs.erase(it);
        }
    for (const fs::path& dir : dirs) {
        if (std::any_of(s_->dirs.begin(), s_->dirs.end(), [&](const auto& d) { return d.second == dir; })) continue;
        const int wd = inotify_add_watch(s_->inotify, dir.c_str(), kEvents | IN_ONLYDIR);
        if (wd < 0) throw IoError(dir.string() + ": cannot watch this directory: " + std::strerror(errno));
        s_->dirs[wd] = dir;
    }
    s_->files = std::move(wanted);
}

void FileWatcher::interrupt() {
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t n = write(s_->wake, &one, sizeof one);
}

std::vector<std::string> FileWatcher::wait(std::chrono::milliseconds timeout, std::chrono::milliseconds quiet) {
    std::set<fs::path> changed;
    Clock::time_point deadline = Clock::now() + timeout;
    const auto reappearLimit = std::chrono::milliseconds(1000);
    Clock::time_point lastChange{};
    for (;;) {
        const auto now = Clock::now();
        if (!changed.empty()) {
            const bool missing = std::any_of(changed.begin(), changed.end(), [](const fs::path& p) {
                std::error_code ec;
                return !fs::exists(p, ec);
            });
            if (now - lastChange >= quiet && (!missing || now - lastChange >= reappearLimit)) break;
            deadline = lastChange + (missing ? reappearLimit : quiet);
        } else if (now >= deadline) {
            return {};
        }
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now).count();
        pollfd fds[2] = {{s_->inotify, POLLIN, 0}, {s_->wake, POLLIN, 0}};
        const int n = poll(fds, 2, int(std::clamp<long long>(left, 0, 1000000)) + 1);
        if (n < 0 && errno != EINTR) throw IoError(std::string("cannot watch files: ") + std::strerror(errno));
        if (n > 0 && (fds[1].revents & POLLIN)) {
            std::uint64_t v = 0;
            [[maybe_unused]] const ssize_t r = read(s_->wake, &v, sizeof v);
            return {};
        }
        if (n <= 0 || !(fds[0].revents & POLLIN)) continue;
        alignas(inotify_event) char buf[16384];
        for (;;) {
            const ssize_t len = read(s_->inotify, buf, sizeof buf);
            if (len <= 0) break;
            for (ssize_t i = 0; i < len;) {
                const auto* e = reinterpret_cast<const inotify_event*>(buf + i);
                i += ssize_t(sizeof(inotify_event) + e->len);
                const auto dir = s_->dirs.find(e->wd);
                if (dir == s_->dirs.end() || e->len == 0) continue;
                const fs::path p = dir->second / e->name;
                if (!s_->files.count(p)) continue;
                changed.insert(p);
                lastChange = Clock::now();
            }
        }
    }
    std::vector<std::string> out;
    for (const fs::path& p : changed) out.push_back(p.string());
    return out;
}

}  // namespace isoforge::view
