#pragma once
/// @file A small HTTP server for `isoforge view`: cpp-httplib (Debian libcpp-httplib-dev), in a module
/// loaded on first use (view/http_module.cpp), so that no other command loads it and the TLS and
/// compression libraries it is linked with.

#include <functional>
#include <memory>
#include <string>

namespace isoforge::view {

struct HttpReply {
    int status = 200;
    std::string type = "text/plain; charset=utf-8";
    std::string body;
};

/// One client's stream of server-sent events (text/event-stream): `next` blocks until there is
/// something to send, puts the text (whole "event: ...\ndata: ...\n\n" records, or a ": keep-alive\n\n"
/// comment) in `out` and returns true; false ends the stream.
using EventStream = std::function<bool(std::string& out)>;

struct HttpRoutes {
    /// GET of any path but the event stream's (the path without its query).
    std::function<HttpReply(const std::string& path)> get;
    /// GET of `eventsPath`: a new stream for each client.
    std::string eventsPath = "/events";
    std::function<EventStream()> openEvents;
};

class HttpServer {
public:
    /// Listens on host:port (port 0: any free port) and serves `routes` from a pool of threads.
    /// @throw IoError when the module cannot be loaded or the address cannot be bound (a port in use
    ///        is named as such).
    HttpServer(const std::string& host, int port, HttpRoutes routes);
    ~HttpServer();  ///< stops
    HttpServer(const HttpServer&) = delete;
    HttpServer& operator=(const HttpServer&) = delete;
    int port() const { return port_; }
    /// Stops listening and ends every connection; returns once the server's threads are done.
    void stop();

private:
    void* handle_ = nullptr;
    int port_ = 0;
    std::unique_ptr<HttpRoutes> routes_;
};

/// Internal to view/: what the module's one exported function, `isoforge_http_module`, returns.
struct HttpModule {
    int abi;
    void* (*start)(const char* host, int port, const HttpRoutes* routes, int* boundPort, std::string* error);
    void (*stop)(void* server);
};
inline constexpr int kHttpModuleAbi = 1;

}  // namespace isoforge::view
