#pragma once
/// @file `isoforge view`'s loop: the model is built in a thread of its own (view/builder.h), the files it
/// is made from are watched (view/watcher.h), and the page (view/page/) is told of every change by
/// server-sent events (view/http.h). A save during a build cancels it; an error keeps the last good model.

#include <atomic>
#include <functional>
#include <memory>
#include <string>

#include "view/builder.h"

namespace isoforge::view {

struct LiveOptions {
    std::string host = "127.0.0.1";
    int port = 0;  ///< 0: any free port
    /// Where three.js is installed (Debian libjs-three); ISOFORGE_THREE_JS overrides it.
    std::string threeJs = "/usr/share/javascript/three";
};

class LiveView {
public:
    /// Starts the server and the first build. @throw IoError when the port cannot be bound, inotify is
    /// missing or three.js is not installed.
    LiveView(ModelRequest request, const LiveOptions& options);
    ~LiveView();
    int port() const;

    /// Watches and rebuilds until `stop` becomes true (polled five times a second); `log` gets a line for
    /// each change, build and error (nothing when it is empty).
    void run(const std::atomic<bool>& stop, const std::function<void(const std::string&)>& log);

    struct State;

private:
    std::unique_ptr<State> s_;
};

}  // namespace isoforge::view
