#include "view/http.h"

#include <mutex>

#include "core/error.h"
#include "core/module.h"

namespace isoforge::view {

namespace {

const HttpModule& httpModule() {
    static std::once_flag once;
    static const HttpModule* module = nullptr;
    std::call_once(once, [] {
        using Entry = const HttpModule* (*)();
        auto entry = reinterpret_cast<Entry>(
            moduleEntry("libisoforge_http.so", "isoforge_http_module", "it serves isoforge view's page"));
        module = entry();
        if (!module || module->abi != kHttpModuleAbi)
            throw IoError("libisoforge_http.so is not a module of this isoforge build");
    });
    return *module;
}

}  // namespace

HttpServer::HttpServer(const std::string& host, int port, HttpRoutes routes)
    : routes_(std::make_unique<HttpRoutes>(std::move(routes))) {
    std::string error;
    handle_ = httpModule().start(host.c_str(), port, routes_.get(), &port_, &error);
    if (!handle_) throw IoError(error);
}

HttpServer::~HttpServer() {
    stop();
}

void HttpServer::stop() {
    if (handle_) httpModule().stop(handle_);
    handle_ = nullptr;
}

}  // namespace isoforge::view
