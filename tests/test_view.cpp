// isoforge view's pieces below the browser: the file watcher (the saves editors make), the files a
// scene is made from, OpenSCAD's dependency lists, and the model builder's stages.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "core/error.h"
#include "csg/openscad.h"
#include "csg/scene.h"
#include "view/builder.h"
#include "view/watcher.h"

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using isoforge::view::FileWatcher;

namespace {

struct TempDir {
    fs::path path;
    TempDir() {
        std::string t = (fs::temp_directory_path() / "isoforge-view-XXXXXX").string();
        EXPECT_NE(mkdtemp(t.data()), nullptr);
        path = t;
    }
    ~TempDir() { fs::remove_all(path); }
};

void write(const fs::path& p, const std::string& text) {
    std::ofstream(p, std::ios::binary) << text;
}

/// Runs `change` on another thread a little after the watcher starts waiting.
std::vector<std::string> changesAfter(FileWatcher& w, std::function<void()> change) {
    std::thread t([&] {
        std::this_thread::sleep_for(50ms);
        change();
    });
    auto got = w.wait(5000ms);
    t.join();
    return got;
}

}  // namespace

TEST(Watcher, SeesEverySaveEditorsMake) {
    TempDir d;
    const fs::path scene = d.path / "a.isf", other = d.path / "b.isf";
    write(scene, "sphere(1);");
    write(other, "sphere(2);");
    FileWatcher w;
    w.watch({scene.string()});
    // In place (truncate and write, as nano and most IDEs).
    EXPECT_EQ(changesAfter(w, [&] { write(scene, "sphere(1.5);"); }), std::vector<std::string>{scene.string()});
    // By rename (vim, emacs, VS Code, atomic writers): a temporary renamed over the file.
    EXPECT_EQ(changesAfter(w,
                           [&] {
                               write(d.path / ".a.isf.swp", "sphere(2);");
                               fs::rename(d.path / ".a.isf.swp", scene);
                           }),
              std::vector<std::string>{scene.string()});
    // Deleted, then created again: reported once it is back, not while it is missing.
    const auto got = changesAfter(w, [&] {
        fs::remove(scene);
        std::this_thread::sleep_for(200ms);
        write(scene, "sphere(3);");
    });
    EXPECT_EQ(got, std::vector<std::string>{scene.string()});
    EXPECT_TRUE(fs::exists(scene));
}

TEST(Watcher, IgnoresOtherFilesAndTimesOut) {
    TempDir d;
    const fs::path scene = d.path / "a.isf";
    write(scene, "sphere(1);");
    FileWatcher w;
    w.watch({scene.string()});
    std::thread t([&] {
        std::this_thread::sleep_for(20ms);
        write(d.path / "unrelated.txt", "x");
    });
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_TRUE(w.wait(300ms).empty());
    t.join();
    EXPECT_GE(std::chrono::steady_clock::now() - t0, 290ms);
}

TEST(Watcher, DebouncesASaveMadeOfManyWrites) {
    TempDir d;
    const fs::path scene = d.path / "a.isf";
    write(scene, "");
    FileWatcher w;
    w.watch({scene.string()});
    std::thread t([&] {
        std::ofstream out(scene, std::ios::binary);
        for (int i = 0; i < 5; ++i) {
            out << "sphere(" << i << ");\n" << std::flush;
            std::this_thread::sleep_for(20ms);
        }
    });
    // 400 ms of quiet: far more than the 20 ms between writes, even on a loaded machine.
    const auto first = w.wait(5000ms, 400ms);
    t.join();
    EXPECT_EQ(first.size(), 1u);
    // The writes all fell within one wait: nothing is left for the next.
    EXPECT_TRUE(w.wait(200ms).empty());
}

TEST(Watcher, WatchesFilesInOtherDirectoriesAndFilesNotYetMade) {
    TempDir d;
    fs::create_directories(d.path / "parts");
    const fs::path scene = d.path / "a.isf", part = d.path / "parts" / "p.vm", later = d.path / "later.stl";
    write(scene, "sphere(1);");
    write(part, "x");
    FileWatcher w;
    w.watch({scene.string(), part.string(), later.string()});
    EXPECT_EQ(changesAfter(w, [&] { write(part, "y"); }), std::vector<std::string>{part.string()});
    EXPECT_EQ(changesAfter(w, [&] { write(later, "solid x\nendsolid x\n"); }),
              std::vector<std::string>{later.string()});
    // A new set replaces the old one.
    w.watch({part.string()});
    std::thread t([&] {
        std::this_thread::sleep_for(20ms);
        write(scene, "sphere(2);");
    });
    EXPECT_TRUE(w.wait(300ms).empty());
    t.join();
}

TEST(Watcher, InterruptWakesAWait) {
    FileWatcher w;
    std::thread t([&] {
        std::this_thread::sleep_for(30ms);
        w.interrupt();
    });
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_TRUE(w.wait(10000ms).empty());
    t.join();
    EXPECT_LT(std::chrono::steady_clock::now() - t0, 5000ms);
}

TEST(SceneFiles, NameTheSceneAndWhatItReads) {
    TempDir d;
    write(d.path / "part.stl",
          "solid t\nfacet normal 0 0 -1\nouter loop\nvertex 0 0 0\nvertex 0 1 0\nvertex 1 0 0\nendloop\nendfacet\n"
          "facet normal 0 -1 0\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 0 1\nendloop\nendfacet\n"
          "facet normal -1 0 0\nouter loop\nvertex 0 0 0\nvertex 0 0 1\nvertex 0 1 0\nendloop\nendfacet\n"
          "facet normal 1 1 1\nouter loop\nvertex 1 0 0\nvertex 0 1 0\nvertex 0 0 1\nendloop\nendfacet\nendsolid t\n");
    write(d.path / "a.isf", "union() { sphere(1); mesh(\"part.stl\"); translate([3,0,0]) mesh(\"part.stl\"); }\n");
    const isoforge::csg::Scene s = isoforge::csg::readScene((d.path / "a.isf").string());
    ASSERT_EQ(s.files.size(), 2u);
    EXPECT_EQ(s.files[0], (d.path / "a.isf").string());
    EXPECT_EQ(fs::path(s.files[1]).filename(), "part.stl");
}

TEST(SceneFiles, OpenScadModelsNameTheirIncludes) {
    if (system("command -v openscad >/dev/null 2>&1") != 0) GTEST_SKIP() << "openscad is not installed";
    TempDir d;
    write(d.path / "inc.scad", "module part() { cube(2); }\n");
    write(d.path / "m.scad", "include <inc.scad>\npart();\n");
    const isoforge::csg::Scene s = isoforge::csg::readScene((d.path / "m.scad").string());
    std::vector<std::string> names;
    for (const auto& f : s.files) names.push_back(fs::path(f).filename().string());
    std::sort(names.begin(), names.end());
    EXPECT_EQ(names, (std::vector<std::string>{"inc.scad", "m.scad"}));
}

TEST(SceneFiles, MakeDependencyLists) {
    using isoforge::csg::parseMakeDependencies;
    EXPECT_EQ(parseMakeDependencies("/tmp/m.csg: \\\n\t/tmp/inc.scad \\\n\t/tmp/m.scad\n"),
              (std::vector<std::string>{"/tmp/inc.scad", "/tmp/m.scad"}));
    EXPECT_EQ(parseMakeDependencies("out.csg: my\\ model.scad lib/a.scad\r\n"),
              (std::vector<std::string>{"my model.scad", "lib/a.scad"}));
    EXPECT_TRUE(parseMakeDependencies("").empty());
    EXPECT_TRUE(parseMakeDependencies("garbage without a colon").empty());
}

namespace {

/// Counts stages; cancels once `cancelAt` progress reports have been made (0: never).
class CountingProgress final : public isoforge::Progress {
public:
    int cancelAt = 0, reports = 0;
    void begin(const std::string&) override { tick(); }
    void update(std::size_t, std::size_t) override { tick(); }
    void end() override {}

private:
    void tick() {
        if (++reports == cancelAt) throw isoforge::view::Cancelled();
    }
};

}  // namespace

TEST(Builder, ACoarseLookThenTheFullModel) {
    TempDir d;
    write(d.path / "a.isf",
          "camera(eye = [0, -6, 3], target = [0, 0, 0], fov = 35);\ndifference() { cube(2, center=true); sphere(1.3); "
          "}\n");
    isoforge::view::ModelRequest rq;
    rq.input = (d.path / "a.isf").string();
    rq.field.resolution = 96;
    rq.coarseResolution = 24;
    CountingProgress progress;
    std::vector<std::string> files;
    std::vector<isoforge::view::ModelUpdate> got;
    isoforge::view::buildModel(rq, progress, files, [&](isoforge::view::ModelUpdate u) { got.push_back(u); });
    ASSERT_EQ(got.size(), 2u);
    EXPECT_EQ(got[0].stage, "coarse");
    EXPECT_EQ(got[1].stage, "full");
    EXPECT_EQ(got[0].glb.substr(0, 4), "glTF");
    EXPECT_LT(got[0].glb.size(), got[1].glb.size());
    EXPECT_NE(got[1].info.find("\"closed\":true"), std::string::npos) << got[1].info;
    EXPECT_NE(got[1].info.find("\"oriented\":true"), std::string::npos) << got[1].info;
    EXPECT_NE(got[1].info.find("\"eye\":[0,-6,3]"), std::string::npos) << got[1].info;
    EXPECT_EQ(files, std::vector<std::string>{rq.input});
    EXPECT_GT(progress.reports, 2);

    // Cancelled part-way: Cancelled comes out, and nothing more is published.
    CountingProgress cancelling;
    cancelling.cancelAt = progress.reports - 1;
    got.clear();
    EXPECT_THROW(
        isoforge::view::buildModel(rq, cancelling, files, [&](isoforge::view::ModelUpdate u) { got.push_back(u); }),
        isoforge::view::Cancelled);
    EXPECT_LE(got.size(), 1u);
}

TEST(Builder, ErrorsAreTheCommandLinesMessages) {
    TempDir d;
    write(d.path / "bad.isf", "sphere(1);\ncube([1,2);\n");
    isoforge::view::ModelRequest rq;
    rq.input = (d.path / "bad.isf").string();
    CountingProgress progress;
    std::vector<std::string> files;
    try {
        isoforge::view::buildModel(rq, progress, files, [](isoforge::view::ModelUpdate) {});
        FAIL() << "no error";
    } catch (const isoforge::ParseError& e) {
        EXPECT_NE(std::string(e.what()).find("bad.isf:2:"), std::string::npos) << e.what();
    }
    EXPECT_EQ(files, std::vector<std::string>{rq.input});  // still watched, so that a fix is seen
}

TEST(Builder, MeshFilesAndVolumesAreShownToo) {
    isoforge::view::ModelRequest rq;
    rq.input = std::string(ISOFORGE_SOURCE_DIR) + "/data/sphere.vdb";
    if (!fs::exists(rq.input)) GTEST_SKIP() << "no data/sphere.vdb";
    CountingProgress progress;
    std::vector<std::string> files;
    std::vector<isoforge::view::ModelUpdate> got;
    isoforge::view::buildModel(rq, progress, files, [&](isoforge::view::ModelUpdate u) { got.push_back(u); });
    ASSERT_EQ(got.size(), 1u);
    EXPECT_EQ(got[0].stage, "full");
    EXPECT_NE(got[0].info.find("\"closed\":true"), std::string::npos) << got[0].info;
}
