#include "view/live.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include <CLI/CLI.hpp>

#include "core/error.h"
#include "view/http.h"
#include "view/json.h"
#include "view/page.h"
#include "view/watcher.h"

namespace isoforge::view {

namespace {

using Clock = std::chrono::steady_clock;

/// The three.js files the page loads (r111's scripts that set the global THREE).
const std::pair<const char*, const char*> kThreeFiles[] = {
    {"/three/three.min.js", "three.min.js"},
    {"/three/OrbitControls.js", "examples/js/controls/OrbitControls.js"},
    {"/three/GLTFLoader.js", "examples/js/loaders/GLTFLoader.js"},
};

std::string slurp(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

}  // namespace

struct LiveView::State {
    ModelRequest request;
    std::string threeDir;
    FileWatcher watcher;
    std::unique_ptr<HttpServer> server;

    std::mutex m;
    std::condition_variable changed;  ///< any of the below changed (builder and event streams wait on it)
    bool stopping = false;
    long long requested = 1;  ///< builds asked for (1: the first); the one running is cancelled when it grows
    long long version = 0;    ///< bumped on every change the page should hear of
    // What the page is shown.
    bool building = false;
    long long buildGeneration = 0;
    std::string progressStage;
    double progressFraction = 0;
    std::string error;              ///< the last build's error; empty after a good one
    long long modelId = 0;          ///< 0: no model yet
    long long cancelledBuilds = 0;  ///< builds a newer change cancelled
    std::string modelStage, modelInfo, modelGlb;
    std::vector<std::string> files;  ///< what the model is made from (watched)
    bool filesChanged = false;
    std::vector<std::string> logLines;

    std::thread builder;

    void bump() {
        ++version;
        changed.notify_all();
    }
    void log(std::string line) { logLines.push_back(std::move(line)); }
    std::string stateJson() {  // under m
        JsonObject o;
        o.num("version", double(version)).num("generation", double(buildGeneration)).flag("building", building);
        o.num("cancelled", double(cancelledBuilds));
        if (building) o.str("progress_stage", progressStage).num("progress", progressFraction);
        if (!error.empty()) o.str("error", error);
        if (modelId > 0) o.num("model", double(modelId)).str("stage", modelStage).raw("info", modelInfo);
        std::string fileList = "[";
        for (const std::string& f : files) fileList += (fileList.size() > 1 ? "," : "") + jsonString(f);
        o.raw("files", fileList + "]");
        return o.text();
    }
    void buildLoop();
    HttpReply get(const std::string& path);
    EventStream openEvents();
};

namespace {

/// Progress of one build, shown on the page (at most ten updates a second); throws Cancelled once a
/// newer build is asked for.
class LiveProgress final : public Progress {
public:
    LiveProgress(LiveView::State& s, long long generation) : s_(s), generation_(generation) {}
    void begin(const std::string& stage) override {
        std::lock_guard lock(s_.m);
        check();
        s_.progressStage = stage;
        s_.progressFraction = 0;
        s_.bump();
    }
    void update(std::size_t done, std::size_t total) override {
        const auto now = Clock::now();
        std::lock_guard lock(s_.m);
        check();
        if (now - last_ < std::chrono::milliseconds(100)) return;
        last_ = now;
        s_.progressFraction = total ? double(done) / double(total) : 0;
        s_.bump();
    }
    void end() override {}

private:
    void check() const {
        if (s_.stopping || s_.requested != generation_) throw Cancelled();
    }
    LiveView::State& s_;
    long long generation_;
    Clock::time_point last_{};
};

}  // namespace

void LiveView::State::buildLoop() {
    long long built = 0;
    for (;;) {
        long long generation;
        {
            std::unique_lock lock(m);
            changed.wait(lock, [&] { return stopping || requested != built; });
            if (stopping) return;
            generation = requested;
            building = true;
            buildGeneration = generation;
            progressStage = "reading";
            progressFraction = 0;
            bump();
        }
        built = generation;
        const auto t0 = Clock::now();
        LiveProgress progress(*this, generation);
        std::vector<std::string> read;
        std::string failure;
        bool cancelled = false;
        try {
            buildModel(request, progress, read, [&](ModelUpdate u) {
                std::lock_guard lock(m);
                if (requested != generation || stopping) throw Cancelled();
                ++modelId;
                modelStage = u.stage;
                modelInfo = std::move(u.info);
                modelGlb = std::move(u.glb);
                error.clear();
                char line[160];
                std::snprintf(line, sizeof line, "%s model after %.2f s", u.stage.c_str(),
                              std::chrono::duration<double>(Clock::now() - t0).count());
                log(line);
                bump();
            });
        } catch (const Cancelled&) {
            cancelled = true;
        } catch (const CLI::Error& e) {
            failure = e.what();
        } catch (const std::exception& e) {
            failure = e.what();
        }
        std::lock_guard lock(m);
        // What to watch: what this build read, and on a failure what the last good one read as well (the
        // error may be in an included file that this build never reached).
        std::vector<std::string> next = read;
        if (!failure.empty() || cancelled)
            for (const std::string& f : files)
                if (std::find(next.begin(), next.end(), f) == next.end()) next.push_back(f);
        if (next != files) {
            files = next;
            filesChanged = true;
            watcher.interrupt();
        }
        if (cancelled) {
            ++cancelledBuilds;
            log("cancelled by a newer change");
            continue;
        }
        building = false;
        error = failure;
        if (!failure.empty()) log("error: " + failure);
        bump();
    }
}

HttpReply LiveView::State::get(const std::string& path) {
    if (path == "/" || path == "/index.html") return {200, "text/html; charset=utf-8", std::string(kIndexHtml)};
    if (path == "/viewer.js") return {200, "text/javascript; charset=utf-8", std::string(kViewerJs)};
    for (const auto& [url, file] : kThreeFiles)
        if (path == url) return {200, "text/javascript; charset=utf-8", slurp(std::filesystem::path(threeDir) / file)};
    std::lock_guard lock(m);
    if (path == "/state") return {200, "application/json", stateJson()};
    if (path == "/model.glb") {
        if (modelId == 0) return {404, "text/plain; charset=utf-8", "no model yet"};
        return {200, "model/gltf-binary", modelGlb};
    }
    return {404, "text/plain; charset=utf-8", path + ": not found"};
}

EventStream LiveView::State::openEvents() {
    auto seen = std::make_shared<long long>(-1);
    return [this, seen](std::string& out) {
        std::unique_lock lock(m);
        // A comment every 3 s keeps a quiet stream open, and finds a closed one (a reloaded or closed tab)
        // soon, so that its thread of the server's pool is freed.
        const bool news = changed.wait_for(lock, std::chrono::seconds(3), [&] { return stopping || version != *seen; });
        if (stopping) return false;
        if (!news) {
            out = ": keep-alive\n\n";
            return true;
        }
        *seen = version;
        out = "event: state\ndata: " + stateJson() + "\n\n";
        return true;
    };
}

LiveView::LiveView(ModelRequest request, const LiveOptions& options) : s_(std::make_unique<State>()) {
    s_->request = std::move(request);
    const char* env = std::getenv("ISOFORGE_THREE_JS");
    s_->threeDir = env && *env ? env : options.threeJs;
    for (const auto& [url, file] : kThreeFiles) {
        std::error_code ec;
        if (!std::filesystem::is_regular_file(std::filesystem::path(s_->threeDir) / file, ec))
            throw IoError("isoforge view needs three.js: " + (std::filesystem::path(s_->threeDir) / file).string() +
                          " is missing (Debian package libjs-three; scripts/setup.sh installs it)");
    }
    if (!s_->request.input.empty()) s_->files = {s_->request.input};
    s_->watcher.watch(s_->files);
    HttpRoutes routes;
    State* st = s_.get();
    routes.get = [st](const std::string& path) { return st->get(path); };
    routes.openEvents = [st] { return st->openEvents(); };
    s_->server = std::make_unique<HttpServer>(options.host, options.port, std::move(routes));
    s_->builder = std::thread([st] { st->buildLoop(); });
}

LiveView::~LiveView() {
    {
        std::lock_guard lock(s_->m);
        s_->stopping = true;
        s_->changed.notify_all();
    }
    if (s_->builder.joinable()) s_->builder.join();
    s_->server->stop();
}

int LiveView::port() const {
    return s_->server->port();
}

void LiveView::run(const std::atomic<bool>& stop, const std::function<void(const std::string&)>& log) {
    while (!stop) {
        const std::vector<std::string> changed = s_->watcher.wait(std::chrono::milliseconds(200));
        std::vector<std::string> lines;
        {
            std::lock_guard lock(s_->m);
            if (!changed.empty()) {
                ++s_->requested;  // cancels the build in progress at its next progress report
                std::string names;
                for (const std::string& f : changed) names += (names.empty() ? "" : ", ") + f;
                s_->log("changed: " + names);
                s_->changed.notify_all();
            }
            if (s_->filesChanged) {
                s_->filesChanged = false;
                try {
                    s_->watcher.watch(s_->files);
                } catch (const IoError& e) {
                    s_->log(std::string("warning: ") + e.what());
                }
            }
            lines.swap(s_->logLines);
        }
        if (log)
            for (const std::string& l : lines) log(l);
    }
}

}  // namespace isoforge::view
