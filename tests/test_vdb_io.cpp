#include <fstream>

#include <gtest/gtest.h>
#include <openvdb/tools/LevelSetSphere.h>

#include "core/error.h"
#include "test_util.h"
#include "volume/vdb_io.h"

using namespace isoforge;

namespace {
std::string slurp(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}
void spit(const std::filesystem::path& p, const std::string& s) {
    std::ofstream out(p, std::ios::binary);
    out << s;
}
}  // namespace

TEST(VdbIo, ReadsTheBundledSphere) {
    auto grid = volume::readFloatGrid(test::sourceDir() / "data/sphere.vdb");
    EXPECT_EQ(grid->getName(), "ls_sphere");
    EXPECT_EQ(grid->getGridClass(), openvdb::GRID_LEVEL_SET);
    EXPECT_EQ(grid->activeVoxelCount(), 270638u);
    EXPECT_NEAR(grid->voxelSize().x(), 0.05, 1e-6);
    const auto s = volume::summarize(*grid);
    EXPECT_EQ(s.indexBounds, openvdb::CoordBBox(openvdb::Coord(-62), openvdb::Coord(62)));
    EXPECT_NE(volume::toString(s).find("level set"), std::string::npos);
}

TEST(VdbIo, ReadsTheSharedSamplesAndPicksGridsByName) {
    const auto dir = test::sharedData() / "volumes/openvdb-samples";
    if (!std::filesystem::exists(dir)) GTEST_SKIP();
    auto smoke = volume::readFloatGrid(dir / "smoke.vdb", std::string("density"));
    EXPECT_EQ(smoke->getGridClass(), openvdb::GRID_FOG_VOLUME);
    EXPECT_EQ(smoke->activeVoxelCount(), 1049275u);
    try {
        volume::readFloatGrid(dir / "smoke.vdb", std::string("temperature"));
        FAIL() << "expected an error";
    } catch (const IoError& e) {
        EXPECT_NE(std::string(e.what()).find("no grid named 'temperature'"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("'density'"), std::string::npos) << e.what();
    }
}

TEST(VdbIo, MissingNonVdbTruncatedAndCorruptFilesGiveClearErrors) {
    const auto dir = test::scratchDir("vdbio");
    EXPECT_THROW(volume::readVdb(dir / "missing.vdb"), IoError);
    spit(dir / "text.vdb", "this is not a volume\n");
    try {
        volume::readVdb(dir / "text.vdb");
        FAIL();
    } catch (const IoError& e) {
        EXPECT_NE(std::string(e.what()).find("not an OpenVDB file"), std::string::npos) << e.what();
    }
    spit(dir / "empty.vdb", "");
    EXPECT_THROW(volume::readVdb(dir / "empty.vdb"), IoError);

    const std::string good = slurp(test::sourceDir() / "data/sphere.vdb");
    ASSERT_GT(good.size(), 100000u);
    // Truncated at many places: always an IoError, never a crash.
    for (std::size_t cut : {std::size_t{8}, std::size_t{16}, std::size_t{64}, std::size_t{200}, std::size_t{1000},
                            std::size_t{4096}, good.size() / 3, good.size() / 2, good.size() - 100, good.size() - 1}) {
        spit(dir / "cut.vdb", good.substr(0, cut));
        EXPECT_THROW(volume::readVdb(dir / "cut.vdb"), IoError) << "cut at " << cut;
    }
    // Bytes flipped in the header and metadata: an error or a grid, never a crash.
    for (std::size_t at : {std::size_t{9}, std::size_t{20}, std::size_t{40}, std::size_t{120}, std::size_t{300}}) {
        std::string bad = good;
        for (std::size_t k = at; k < at + 4; ++k) bad[k] = static_cast<char>(~bad[k]);
        spit(dir / "bad.vdb", bad);
        try {
            volume::readVdb(dir / "bad.vdb");
        } catch (const IoError&) {
        }
    }
    std::filesystem::remove_all(dir);
}

TEST(VdbIo, WritesAtomicallyAndRoundTrips) {
    volume::initializeOpenVdb();
    const auto dir = test::scratchDir("vdbwrite");
    auto grid = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(1.f, openvdb::Vec3f(0.f), 0.1f);
    grid->setName("ball");
    volume::writeVdb(dir / "ball.vdb", {grid});
    auto back = volume::readFloatGrid(dir / "ball.vdb");
    EXPECT_EQ(back->activeVoxelCount(), grid->activeVoxelCount());
    EXPECT_EQ(back->getName(), "ball");
    // Only the target is left in the directory (no temporary files).
    EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator()), 1);
    EXPECT_THROW(volume::writeVdb(dir / "no/such/dir/x.vdb", {grid}), IoError);
    std::filesystem::remove_all(dir);
}
