// The HTTP module behind view/http.h: cpp-httplib 0.11 (Debian libcpp-httplib-dev), loaded by
// `isoforge view` only. Its server runs in a thread of its own; requests are answered by the routes'
// callbacks from httplib's pool of threads.
#include <httplib.h>

#include <thread>

#include "view/http.h"

namespace {

using isoforge::view::HttpReply;
using isoforge::view::HttpRoutes;

struct Running {
    httplib::Server server;
    std::thread thread;
};

void* start(const char* host, int port, const HttpRoutes* routes, int* boundPort, std::string* error) {
    auto r = std::make_unique<Running>();
    httplib::Server& s = r->server;
    // Shorter than httplib's 5 s, so that stop() does not wait long for idle keep-alive connections.
    s.set_keep_alive_timeout(1);
    // Each open event stream holds a thread of the pool until it ends: room for many tabs and reloads
    // (httplib's default is 8).
    s.new_task_queue = [] { return new httplib::ThreadPool(32); };
    // httplib's default also sets SO_REUSEPORT, with which a second server binds a port in use and the
    // two share its connections; SO_REUSEADDR alone lets a restarted server have its port back.
    s.set_socket_options([](int sock) {
        const int yes = 1;
        setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    });
    s.Get(routes->eventsPath, [routes](const httplib::Request&, httplib::Response& res) {
        res.set_header("Cache-Control", "no-store");
        auto stream = std::make_shared<isoforge::view::EventStream>(routes->openEvents());
        res.set_chunked_content_provider("text/event-stream", [stream](std::size_t, httplib::DataSink& sink) {
            std::string text;
            if (!(*stream)(text)) {
                sink.done();
                return true;
            }
            return sink.write(text.data(), text.size());
        });
    });
    s.Get(".*", [routes](const httplib::Request& req, httplib::Response& res) {
        const HttpReply reply = routes->get(req.path);
        res.status = reply.status;
        res.set_header("Cache-Control", "no-store");
        res.set_content(reply.body, reply.type.c_str());
    });
    if (port == 0) {
        const int p = s.bind_to_any_port(host);
        if (p < 0) {
            *error = std::string("cannot listen on ") + host + ": no free port";
            return nullptr;
        }
        *boundPort = p;
    } else {
        if (!s.bind_to_port(host, port)) {
            *error = std::string("cannot listen on ") + host + ":" + std::to_string(port) +
                     ": the port is in use, or the address is not this machine's (choose another with --port, or "
                     "--port 0 for any free one)";
            return nullptr;
        }
        *boundPort = port;
    }
    Running* raw = r.get();
    raw->thread = std::thread([raw] { raw->server.listen_after_bind(); });
    return r.release();
}

void stop(void* handle) {
    auto* r = static_cast<Running*>(handle);
    r->server.stop();
    if (r->thread.joinable()) r->thread.join();
    delete r;
}

const isoforge::view::HttpModule kModule{isoforge::view::kHttpModuleAbi, start, stop};

}  // namespace

extern "C" __attribute__((visibility("default"))) const isoforge::view::HttpModule* isoforge_http_module() {
    return &kModule;
}
