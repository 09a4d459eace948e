#include <cmath>
#include <functional>
#include <map>
#include <random>

#include <gtest/gtest.h>
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/LevelSetPlatonic.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/LevelSetUtil.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/global_control.h>
#include <glm/geometric.hpp>

#include "test_util.h"
#include "volume/marching_cubes.h"
#include "volume/vdb_io.h"

using namespace isoforge;
using openvdb::Coord;
using openvdb::FloatGrid;
using openvdb::Vec3f;

namespace {

struct Init {
    Init() { volume::initializeOpenVdb(); }
} init;

/// A narrow-band level set of an analytic signed distance function (world units), inside filled.
FloatGrid::Ptr levelSetFromSdf(const std::function<double(const openvdb::Vec3d&)>& sdf, double halfExtent, float voxel,
                               float halfWidth = 3.f) {
    auto grid = FloatGrid::create(halfWidth * voxel);
    grid->setTransform(openvdb::math::Transform::createLinearTransform(voxel));
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    auto acc = grid->getAccessor();
    const int n = static_cast<int>(std::ceil(halfExtent / voxel)) + 4;
    for (int i = -n; i <= n; ++i)
        for (int j = -n; j <= n; ++j)
            for (int k = -n; k <= n; ++k) {
                const double d = sdf(openvdb::Vec3d(i, j, k) * voxel);
                if (std::abs(d) < halfWidth * voxel) acc.setValue(Coord(i, j, k), static_cast<float>(d));
            }
    openvdb::tools::signedFloodFill(grid->tree());
    return grid;
}

double torusSdf(const openvdb::Vec3d& p, double R, double r) {
    const double q = std::sqrt(p.x() * p.x() + p.y() * p.y()) - R;
    return std::sqrt(q * q + p.z() * p.z()) - r;
}

mesh::TriMesh meshOf(const FloatGrid& g, float iso = 0.f, volume::InsideSide side = volume::InsideSide::Auto) {
    volume::MeshingOptions o;
    o.isovalue = iso;
    o.inside = side;
    return volume::extractIsosurface(g, o);
}

}  // namespace

TEST(MarchingCubes, SphereAreaAndVolumeMatchAnalyticAtRadius50Voxels) {
    const float R = 50.f;
    auto grid = openvdb::tools::createLevelSetSphere<FloatGrid>(R, Vec3f(0.3f, -0.2f, 0.1f), 1.f, 3.f);
    const auto r = test::expectClosedSurface(meshOf(*grid), "sphere R=50");
    const double area = 4.0 * M_PI * R * R, volume = 4.0 / 3.0 * M_PI * R * R * R;
    EXPECT_NEAR(r.area, area, 0.005 * area);
    EXPECT_NEAR(r.volume, volume, 0.005 * volume);
    EXPECT_EQ(r.components, 1u);
    EXPECT_EQ(*r.genus(), 0);
}

TEST(MarchingCubes, SpheresAtSeveralResolutionsAndCentres) {
    for (float voxel : {0.5f, 0.2f, 0.1f, 0.037f})
        for (Vec3f c : {Vec3f(0.f), Vec3f(0.51f, -1.33f, 2.7f), Vec3f(-13.f, 8.f, -4.f)}) {
            auto grid = openvdb::tools::createLevelSetSphere<FloatGrid>(1.5f, c, voxel, 3.f);
            const std::string what = "sphere voxel " + std::to_string(voxel);
            const auto r = test::expectClosedSurface(meshOf(*grid), what);
            EXPECT_EQ(r.components, 1u) << what;
            EXPECT_EQ(*r.genus(), 0) << what;
            // Vertices lie on the sphere to a small fraction of a voxel.
            auto m = meshOf(*grid);
            double worst = 0;
            for (const auto& p : m.positions)
                worst = std::max(worst, std::abs(glm::length(p - glm::vec3(c.x(), c.y(), c.z())) - 1.5));
            EXPECT_LT(worst, 0.1 * voxel) << what;
        }
}

TEST(MarchingCubes, PlatonicSolidsAndBoxes) {
    for (int faces : {4, 6, 8, 12, 20})
        for (float voxel : {0.1f, 0.043f}) {
            auto grid = openvdb::tools::createLevelSetPlatonic<FloatGrid>(faces, 1.f, Vec3f(0.2f, 0.f, -0.1f), voxel);
            const auto r = test::expectClosedSurface(meshOf(*grid), "platonic " + std::to_string(faces));
            EXPECT_EQ(*r.genus(), 0);
            EXPECT_EQ(r.components, 1u);
        }
    auto box = openvdb::tools::createLevelSetBox<FloatGrid>(openvdb::BBoxd({-1, -2, -0.5}, {1.5, 1, 0.5}),
                                                            *openvdb::math::Transform::createLinearTransform(0.05));
    const auto r = test::expectClosedSurface(meshOf(*box), "box");
    EXPECT_NEAR(r.volume, 2.5 * 3 * 1, 0.01 * 7.5);
}

TEST(MarchingCubes, TorusHasGenusOne) {
    for (float voxel : {0.08f, 0.04f, 0.02f}) {
        auto grid = levelSetFromSdf([](const openvdb::Vec3d& p) { return torusSdf(p, 1.0, 0.35); }, 1.4, voxel);
        const auto r = test::expectClosedSurface(meshOf(*grid), "torus");
        EXPECT_EQ(*r.genus(), 1);
        const double volume = 2 * M_PI * M_PI * 1.0 * 0.35 * 0.35;
        EXPECT_NEAR(r.volume, volume, 0.02 * volume);
    }
}

TEST(MarchingCubes, CsgOfLevelSets) {
    auto xf = openvdb::math::Transform::createLinearTransform(0.04);
    // A box with a sphere removed from a corner, and two overlapping spheres.
    auto box = openvdb::tools::createLevelSetBox<FloatGrid>(openvdb::BBoxd({-1, -1, -1}, {1, 1, 1}), *xf);
    auto ball = openvdb::tools::createLevelSetSphere<FloatGrid>(0.8f, Vec3f(1.f, 1.f, 1.f), 0.04f);
    openvdb::tools::csgDifference(*box, *ball);
    auto r = test::expectClosedSurface(meshOf(*box), "box - sphere");
    const double expected = 8.0 - (4.0 / 3.0 * M_PI * 0.512) / 8.0;
    EXPECT_NEAR(r.volume, expected, 0.01 * expected);
    EXPECT_EQ(*r.genus(), 0);

    auto a = openvdb::tools::createLevelSetSphere<FloatGrid>(1.f, Vec3f(0.f), 0.04f);
    auto b = openvdb::tools::createLevelSetSphere<FloatGrid>(1.f, Vec3f(1.2f, 0.f, 0.f), 0.04f);
    openvdb::tools::csgUnion(*a, *b);
    r = test::expectClosedSurface(meshOf(*a), "sphere + sphere");
    EXPECT_EQ(r.components, 1u);

    // A sphere with a cylinder drilled through it: genus 1.
    auto s = levelSetFromSdf(
        [](const openvdb::Vec3d& p) {
            const double sphere = p.length() - 1.0;
            const double cyl = std::sqrt(p.x() * p.x() + p.y() * p.y()) - 0.4;
            return std::max(sphere, -cyl);
        },
        1.1, 0.03f);
    r = test::expectClosedSurface(meshOf(*s), "drilled sphere");
    EXPECT_EQ(*r.genus(), 1);
}

TEST(MarchingCubes, AgreesWithOpenVdbVolumeToMesh) {
    auto grid = openvdb::tools::createLevelSetPlatonic<FloatGrid>(12, 2.f, Vec3f(0.1f), 0.05f);
    const auto ours = mesh::check(meshOf(*grid));
    std::vector<Vec3f> points;
    std::vector<openvdb::Vec3I> tris;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(*grid, points, tris, quads, 0.0, 0.0);
    mesh::TriMesh theirs;
    for (const auto& p : points) theirs.positions.emplace_back(p.x(), p.y(), p.z());
    // OpenVDB's quads are ordered the other way round from our counter-clockwise convention.
    for (const auto& q : quads) {
        theirs.triangles.emplace_back(q[0], q[2], q[1]);
        theirs.triangles.emplace_back(q[0], q[3], q[2]);
    }
    const auto ref = mesh::check(theirs);
    EXPECT_NEAR(ours.area, ref.area, 0.01 * ref.area);
    EXPECT_NEAR(std::abs(ours.volume), std::abs(ref.volume), 0.01 * std::abs(ref.volume));
}

TEST(MarchingCubes, SingleVoxelAndLeafBoundaries) {
    // One inside voxel: an octahedron of 8 triangles around it.
    for (Coord c :
         {Coord(0, 0, 0), Coord(7, 7, 7), Coord(8, 8, 8), Coord(-1, -1, -1), Coord(-8, 7, 8), Coord(15, -9, 0)}) {
        auto grid = FloatGrid::create(1.f);
        grid->setGridClass(openvdb::GRID_LEVEL_SET);
        grid->tree().setValue(c, -1.f);
        auto m = meshOf(*grid);
        const auto r = test::expectClosedSurface(m, "single voxel");
        EXPECT_EQ(r.triangles, 8u);
        EXPECT_EQ(r.vertices, 6u);
        EXPECT_EQ(*r.genus(), 0);
    }
    // Blocks of inside voxels straddling leaf corners in every direction.
    auto grid = FloatGrid::create(1.f);
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    for (int i = 5; i <= 10; ++i)
        for (int j = -3; j <= 2; ++j)
            for (int k = 6; k <= 9; ++k) grid->tree().setValue(Coord(i, j, k), -0.5f);
    const auto r = test::expectClosedSurface(meshOf(*grid), "leaf-straddling block");
    EXPECT_EQ(r.components, 1u);
}

TEST(MarchingCubes, InconsistentTilesNeverGiveBadIndices) {
    // Inactive 8^3 tiles of opposite signs side by side, next to a leaf (what an inconsistent
    // sampler can make; the cow mesh once did): every index must name a vertex.
    auto grid = FloatGrid::create(1.f);
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    grid->tree().addTile(1, Coord(0, 0, 0), -1.f, false);
    grid->tree().addTile(1, Coord(0, 0, 8), 1.f, false);
    grid->tree().addTile(1, Coord(0, 8, 0), -1.f, false);
    grid->tree().setValue(Coord(9, 3, 3), -1.f);  // a leaf at +x whose lower neighbours are the tiles
    grid->tree().setValue(Coord(3, 3, -5), 0.5f);
    const auto m = meshOf(*grid);
    ASSERT_GT(m.triangles.size(), 0u);
    for (const auto& t : m.triangles)
        for (int k = 0; k < 3; ++k) ASSERT_LT(t[k], m.positions.size());
    const auto r = mesh::check(m);
    EXPECT_EQ(r.nonManifoldEdges, 0u);
    EXPECT_EQ(r.outOfRangeIndices, 0u);
}

TEST(MarchingCubes, RandomNoiseAtManyIsoValuesIncludingExactHits) {
    std::mt19937 rng(12345);
    std::uniform_int_distribution<int> level(-4, 4);
    std::uniform_real_distribution<float> real(-1.f, 1.f);
    for (int trial = 0; trial < 6; ++trial) {
        auto grid = FloatGrid::create(10.f);  // background: outside at every iso below 10
        grid->setGridClass(openvdb::GRID_UNKNOWN);
        auto acc = grid->getAccessor();
        const bool quantized = trial % 2 == 0;  // quantized values make the iso hit voxel values exactly
        for (int i = -11; i < 13; ++i)
            for (int j = -5; j < 19; ++j)
                for (int k = 3; k < 21; ++k) acc.setValue(Coord(i, j, k), quantized ? 0.25f * level(rng) : real(rng));
        for (float iso : {-0.75f, -0.5f, -0.1f, 0.f, 0.25f, 0.3f, 0.5f, 0.99f}) {
            auto m = meshOf(*grid, iso, volume::InsideSide::Below);
            test::expectClosedSurface(m, "noise trial " + std::to_string(trial) + " iso " + std::to_string(iso));
        }
    }
}

TEST(MarchingCubes, FogVolumesThinSheetsAndActiveTiles) {
    // A one-voxel-thick sheet of density, diagonal staircase included.
    auto sheet = FloatGrid::create(0.f);
    sheet->setGridClass(openvdb::GRID_FOG_VOLUME);
    for (int i = -20; i < 20; ++i)
        for (int j = -20; j < 20; ++j) {
            sheet->tree().setValue(Coord(i, j, 0), 1.f);
            sheet->tree().setValue(Coord(i, j, (i + j) / 2 + 30), 1.f);
        }
    for (float iso : {0.2f, 0.5f, 0.999f}) test::expectClosedSurface(meshOf(*sheet, iso), "sheet");

    // Dense regions stored as active tiles, touching leaves and background.
    auto fog = FloatGrid::create(0.f);
    fog->setGridClass(openvdb::GRID_FOG_VOLUME);
    fog->tree().fill(openvdb::CoordBBox(Coord(0), Coord(255)), 1.f, true);                // 128^3 and 8^3 tiles
    fog->tree().fill(openvdb::CoordBBox(Coord(256, 0, 0), Coord(263, 7, 7)), 1.f, true);  // leaf-sized tile
    fog->tree().fill(openvdb::CoordBBox(Coord(-300, 3, 5), Coord(-280, 20, 9)), 0.7f, true);
    fog->tree().setValue(Coord(100, 256, 100), 1.f);  // a voxel touching the big tile's face
    volume::MeshingStats stats;
    volume::MeshingOptions o;
    o.isovalue = 0.5f;
    auto m = volume::extractIsosurface(*fog, o, &stats);
    const auto r = test::expectClosedSurface(m, "active tiles");
    // A 256^3 box (surface half a voxel outside the boundary voxels), the 8^3 tile on its side, and
    // the slab of 0.7 (surface 0.2857 voxels out: 20.57 x 17.57 x 4.57).
    const double expected = 256.0 * 256 * 256 + 512 + 20.571 * 17.571 * 4.571;
    EXPECT_NEAR(r.volume, expected, 0.02 * expected);
    EXPECT_EQ(r.components, 2u);
    // Work follows the surface: the 256^3 interior is not visited voxel by voxel.
    EXPECT_LT(stats.blocks, 20000u);
}

TEST(MarchingCubes, SmokeFogVolumeAtManyIsoValues) {
    const auto path = test::sharedData() / "volumes/openvdb-samples/smoke.vdb";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "no shared data";
    auto grid = volume::readFloatGrid(path, std::string("density"));
    for (float iso : {0.01f, 0.2f, 0.5f, 1.f, 3.f}) {
        auto m = meshOf(*grid, iso);
        test::expectClosedSurface(m, "smoke iso " + std::to_string(iso));
    }
}

TEST(MarchingCubes, SameBytesWhateverTheThreadCount) {
    auto grid = openvdb::tools::createLevelSetSphere<FloatGrid>(40.f, Vec3f(0.5f), 1.f, 3.f);
    mesh::TriMesh reference;
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        reference = meshOf(*grid);
    }
    for (int threads : {2, 3, 8}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        auto m = meshOf(*grid);
        ASSERT_EQ(m.positions.size(), reference.positions.size());
        ASSERT_EQ(m.triangles.size(), reference.triangles.size());
        EXPECT_EQ(0,
                  std::memcmp(m.positions.data(), reference.positions.data(), m.positions.size() * sizeof(glm::vec3)));
        EXPECT_EQ(0,
                  std::memcmp(m.triangles.data(), reference.triangles.data(), m.triangles.size() * sizeof(glm::uvec3)));
    }
}

TEST(MarchingCubes, NormalsPointOutwardAndIndexSpaceWorks) {
    const Vec3f c(1.f, 2.f, 3.f);
    auto grid = openvdb::tools::createLevelSetSphere<FloatGrid>(2.f, c, 0.1f, 3.f);
    volume::MeshingOptions o;
    o.normals = true;
    auto m = volume::extractIsosurface(*grid, o);
    ASSERT_EQ(m.normals.size(), m.positions.size());
    for (std::size_t i = 0; i < m.positions.size(); ++i) {
        const glm::vec3 radial = glm::normalize(m.positions[i] - glm::vec3(c.x(), c.y(), c.z()));
        ASSERT_GT(glm::dot(radial, m.normals[i]), 0.99f);
    }
    o.worldSpace = false;
    auto mi = volume::extractIsosurface(*grid, o);
    ASSERT_EQ(mi.positions.size(), m.positions.size());
    EXPECT_NEAR(mi.positions[0].x * 0.1f, m.positions[0].x, 1e-4f);

    // Fog volumes: normals point away from the dense region.
    auto fog = openvdb::tools::createLevelSetSphere<FloatGrid>(2.f, c, 0.1f, 3.f);
    openvdb::tools::sdfToFogVolume(*fog);
    o.worldSpace = true;
    o.isovalue = 0.5f;
    auto mf = volume::extractIsosurface(*fog, o);
    test::expectClosedSurface(mf, "fog sphere");
    for (std::size_t i = 0; i < mf.positions.size(); ++i)
        ASSERT_GT(glm::dot(glm::normalize(mf.positions[i] - glm::vec3(c.x(), c.y(), c.z())), mf.normals[i]), 0.9f);
}

TEST(MarchingCubes, EmptyAndUniformGridsGiveEmptyMeshes) {
    auto empty = FloatGrid::create(1.f);
    EXPECT_TRUE(meshOf(*empty).empty());
    auto full = FloatGrid::create(-1.f);
    full->setGridClass(openvdb::GRID_LEVEL_SET);
    full->tree().fill(openvdb::CoordBBox(Coord(0), Coord(20)), -1.f, true);
    EXPECT_TRUE(meshOf(*full).empty());  // inside everywhere: no surface
}

namespace {

/// Checks crossedCellBoxes against every cell of `region` visited one by one: each crossed cell lies
/// in a box, and every box is tight (its faces touch crossed cells).
void expectBoxesHoldEveryCrossedCell(const FloatGrid& g, float iso, bool below, const openvdb::CoordBBox& region,
                                     int brick, const std::string& what) {
    const auto boxes =
        volume::crossedCellBoxes(g, iso, below ? volume::InsideSide::Below : volume::InsideSide::Above, brick);
    auto acc = g.getConstAccessor();
    auto inside = [&](const Coord& c) {
        const float v = acc.getValue(c);
        return below ? v < iso : v > iso;
    };
    auto crossed = [&](const Coord& c) {
        int n = 0;
        for (int i = 0; i < 8; ++i) n += inside(c.offsetBy(i >> 2, (i >> 1) & 1, i & 1));
        return n > 0 && n < 8;
    };
    // Index the boxes by their lower cell's 8^3 block (each box lies in one block).
    std::map<Coord, std::vector<openvdb::CoordBBox>> byBlock;
    for (const auto& b : boxes) {
        EXPECT_LE(b.max().x() - b.min().x(), brick) << what;
        byBlock[Coord(b.min().x() & ~7, b.min().y() & ~7, b.min().z() & ~7)].push_back(b);
    }
    std::size_t count = 0, missing = 0;
    for (auto it = region.begin(); it; ++it) {
        const Coord c = *it;
        if (!crossed(c)) continue;
        ++count;
        bool found = false;
        for (const auto& b : byBlock[Coord(c.x() & ~7, c.y() & ~7, c.z() & ~7)])
            found = found || (c.x() >= b.min().x() && c.x() < b.max().x() && c.y() >= b.min().y() &&
                              c.y() < b.max().y() && c.z() >= b.min().z() && c.z() < b.max().z());
        missing += !found;
    }
    EXPECT_GT(count, 0u) << what;
    EXPECT_EQ(missing, 0u) << what << ": crossed cells outside every box, of " << count;
    // Tight: each box's lowest and highest cells along x hold a crossed cell.
    std::size_t loose = 0;
    for (const auto& b : boxes) {
        bool lo = false, hi = false;
        for (int y = b.min().y(); y < b.max().y(); ++y)
            for (int z = b.min().z(); z < b.max().z(); ++z) {
                lo = lo || crossed(Coord(b.min().x(), y, z));
                hi = hi || crossed(Coord(b.max().x() - 1, y, z));
            }
        loose += !(lo && hi);
    }
    EXPECT_EQ(loose, 0u) << what;
}

}  // namespace

TEST(MarchingCubes, CrossedCellBoxesHoldEveryCrossedCell) {
    // What the ray marcher's depth pre-pass relies on, on a level set, noise (crossings everywhere,
    // exact hits), and a fog volume of active tiles next to leaves and background.
    auto sphere = openvdb::tools::createLevelSetSphere<FloatGrid>(9.3f, Vec3f(0.4f, -0.2f, 0.1f), 1.f, 3.f);
    for (int brick : {2, 4, 8})
        expectBoxesHoldEveryCrossedCell(*sphere, 0.f, true, openvdb::CoordBBox(Coord(-16), Coord(16)), brick,
                                        "sphere, brick " + std::to_string(brick));
    expectBoxesHoldEveryCrossedCell(*sphere, 1.5f, true, openvdb::CoordBBox(Coord(-16), Coord(16)), 2,
                                    "sphere iso 1.5");

    std::mt19937 rng(7);
    std::uniform_int_distribution<int> level(-2, 2);
    auto noise = FloatGrid::create(10.f);
    noise->setGridClass(openvdb::GRID_UNKNOWN);
    for (int i = -9; i < 11; ++i)
        for (int j = -5; j < 13; ++j)
            for (int k = 3; k < 17; ++k) noise->tree().setValue(Coord(i, j, k), 0.5f * float(level(rng)));
    for (float iso : {-0.5f, 0.f, 0.3f})
        expectBoxesHoldEveryCrossedCell(*noise, iso, true, openvdb::CoordBBox(Coord(-12, -8, 0), Coord(13, 15, 19)), 2,
                                        "noise iso " + std::to_string(iso));

    auto fog = FloatGrid::create(0.f);
    fog->setGridClass(openvdb::GRID_FOG_VOLUME);
    fog->tree().fill(openvdb::CoordBBox(Coord(0), Coord(127)), 1.f, true);                // a 128^3 tile
    fog->tree().fill(openvdb::CoordBBox(Coord(128, 0, 0), Coord(135, 7, 7)), 1.f, true);  // a leaf-sized tile
    fog->tree().setValue(Coord(60, 128, 60), 1.f);                                        // a voxel on its face
    fog->tree().setValue(Coord(-3, 5, 5), 0.9f);
    expectBoxesHoldEveryCrossedCell(*fog, 0.5f, false, openvdb::CoordBBox(Coord(-5), Coord(140)), 2, "fog tiles");
}

namespace {

struct StopMeshing : std::exception {};

/// Throws from update() after `after` reports, as a cancelled caller does (isoforge view, Python's
/// Ctrl-C); end() throws too when `endThrows`, as the Python package's once did.
class CancellingProgress final : public isoforge::Progress {
public:
    CancellingProgress(int after, bool endThrows) : after_(after), endThrows_(endThrows) {}
    void begin(const std::string&) override {}
    void update(std::size_t, std::size_t) override {
        if (++reports_ > after_) {
            cancelled_ = true;
            throw StopMeshing();
        }
    }
    void end() override {
        if (endThrows_ && cancelled_) throw StopMeshing();
    }

private:
    std::atomic<int> reports_{0};
    const int after_;
    const bool endThrows_;
    std::atomic<bool> cancelled_{false};
};

}  // namespace

// A cancellation unwinds the mesher (through TBB, its progress ticker's destructor) to the caller, and
// never ends the process (std::terminate, which the Python package's Ctrl-C once met mid-meshing).
TEST(MarchingCubes, ACancellingProgressStopsTheMesherCleanly) {
    auto grid = openvdb::tools::createLevelSetSphere<FloatGrid>(60.f, Vec3f(0.f), 1.f, 3.f);
    for (const bool endThrows : {false, true}) {
        CancellingProgress p(3, endThrows);
        isoforge::volume::MeshingOptions o;
        o.progress = &p;
        EXPECT_THROW(isoforge::volume::extractIsosurface(*grid, o), StopMeshing) << "end() throws: " << endThrows;
    }
}
