#pragma once
/// @file Watching the files a model is made from, with Linux's inotify: the directories that hold them
/// are watched, not the files, so that saves by rename (write a temporary, rename it over the file, as
/// vim, emacs, VS Code and atomic writers do), delete-and-re-create and in-place writes are all seen.

#include <chrono>
#include <string>
#include <vector>

namespace isoforge::view {

class FileWatcher {
public:
    /// @throw IoError when inotify is not available.
    FileWatcher();
    ~FileWatcher();
    FileWatcher(const FileWatcher&) = delete;
    FileWatcher& operator=(const FileWatcher&) = delete;

    /// Watches these files from now on (instead of those given before). Files that do not exist yet are
    /// watched too: their creation is a change. @throw IoError when a directory cannot be watched.
    void watch(const std::vector<std::string>& files);

    /// Waits up to `timeout` for a change to a watched file; after one, waits until `quiet` passes with no
    /// further change (an editor's save is several events: the debounce), and, while a changed file is
    /// missing, up to a second more for it to come back (delete, then write). Returns the changed files
    /// (absolute paths, each once), or nothing on a timeout or an interrupt().
    std::vector<std::string> wait(std::chrono::milliseconds timeout,
                                  std::chrono::milliseconds quiet = std::chrono::milliseconds(60));

    /// Makes a wait() in another thread return now (thread-safe).
    void interrupt();

private:
    struct State;
    State* s_;
};

}  // namespace isoforge::view
