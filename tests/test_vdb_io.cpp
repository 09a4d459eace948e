#include <fstream>
#include <random>

#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/tools/LevelSetSphere.h>

#include "core/error.h"
#include "core/file_read_buffer.h"
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

TEST(VdbIo, TheFileBufferReadsSeeksAndTellsAsAnIfstreamDoes) {
    // core/file_read_buffer.h keeps the position itself (OpenVDB asks for it on every leaf). Against
    // std::ifstream on a real file, with a small buffer so that reads, seeks and tells cross its edges:
    // the same bytes, positions, short reads at the end and failures.
    const auto path = test::sourceDir() / "data/sphere.vdb";
    const auto size = std::int64_t(std::filesystem::file_size(path));
    FileReadBuffer buffer(path, 4096);
    ASSERT_TRUE(buffer.isOpen());
    std::istream ours(&buffer);
    std::ifstream theirs(path, std::ios::binary);
    std::mt19937 random(7);
    const auto pick = [&](std::int64_t lo, std::int64_t hi) {
        return std::uniform_int_distribution<std::int64_t>(lo, hi)(random);
    };
    ours.read(nullptr, 0);  // as OpenVDB reads an empty string (fuzz_vdb: UBSan on memcpy from null)
    EXPECT_TRUE(ours.good());
    for (int step = 0; step < 20000; ++step) {
        SCOPED_TRACE("step " + std::to_string(step));
        switch (pick(0, 5)) {
            case 0: {  // a read of up to three buffers
                const auto n = pick(0, 3 * 4096 + 7);
                std::string a(std::size_t(n), '\0'), b(std::size_t(n), '\0');
                ours.read(a.data(), n);
                theirs.read(b.data(), n);
                ASSERT_EQ(ours.gcount(), theirs.gcount());
                ASSERT_EQ(a, b);
                break;
            }
            case 1:
                ASSERT_EQ(ours.get(), theirs.get());
                break;
            case 2: {
                const auto to = pick(0, size + 10);
                ours.seekg(to);
                theirs.seekg(to);
                break;
            }
            case 3: {
                const auto by = pick(-9000, 9000);
                ours.seekg(by, std::ios::cur);
                theirs.seekg(by, std::ios::cur);
                break;
            }
            case 4: {
                const auto back = pick(-5000, 0);
                ours.seekg(back, std::ios::end);
                theirs.seekg(back, std::ios::end);
                break;
            }
            default:
                ASSERT_EQ(std::int64_t(ours.tellg()), std::int64_t(theirs.tellg()));
        }
        ASSERT_EQ(ours.good(), theirs.good());
        ASSERT_EQ(ours.eof(), theirs.eof());
        if (!ours.good()) {
            ours.clear();
            theirs.clear();
        }
    }
}

TEST(VdbIo, ReadsTheSameTreeAsOpenVdbsOwnFileReader) {
    // readVdb reads through core/file_read_buffer.h; OpenVDB's io::File (memory mapped, delayed loading)
    // is the reference: every active voxel and value the same, on the bundled sphere and a level set of
    // 150,000 leaves written here (whose leaves cross the buffer's edges).
    const auto dir = test::scratchDir("vdb-file-buffer");
    auto big = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(1.f, openvdb::Vec3f(0.f), 1.f / 150, 3.f);
    volume::writeVdb(dir / "big.vdb", {big});
    for (const auto& path : {test::sourceDir() / "data/sphere.vdb", dir / "big.vdb"}) {
        SCOPED_TRACE(path.string());
        openvdb::io::File file(path.string());
        file.open();
        const auto reference = openvdb::gridPtrCast<openvdb::FloatGrid>(file.getGrids()->front());
        file.close();
        const auto ours = volume::readFloatGrid(path);
        ASSERT_EQ(ours->activeVoxelCount(), reference->activeVoxelCount());
        ASSERT_EQ(ours->tree().leafCount(), reference->tree().leafCount());
        std::size_t differ = 0;
        const auto acc = reference->getConstAccessor();
        for (auto it = ours->cbeginValueOn(); it; ++it)
            if (!acc.isValueOn(it.getCoord()) || acc.getValue(it.getCoord()) != *it) ++differ;
        EXPECT_EQ(differ, 0u);
    }
}
