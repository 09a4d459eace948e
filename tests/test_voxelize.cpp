// Mesh to volume and back: the closed cow and vase voxelized and meshed by our marching cubes keep
// their volume within 1%; the open bunny becomes an unsigned band.
#include <gtest/gtest.h>

#include "mesh/io.h"
#include "test_util.h"
#include "volume/marching_cubes.h"
#include "volume/sample.h"
#include "volume/voxelize.h"

using namespace isoforge;

TEST(Voxelize, ClosedMeshesRoundTripWithinOnePercent) {
    for (const char* f : {"meshes/cow/cow.obj", "meshes/vase/Vase.stl"}) {
        const mesh::TriMesh in = mesh::readMesh(test::sharedData() / f);
        const mesh::Bounds b = mesh::bounds(in);
        volume::VoxelizeOptions o;
        o.voxelSize = volume::voxelSizeForResolution(implicit::Box3{b.min, b.max}, 200);
        const volume::VoxelizeResult r = volume::voxelize(in, o);
        EXPECT_TRUE(r.isSigned) << f;
        const auto out = test::expectClosedSurface(volume::extractIsosurface(*r.grid), f);
        const double v = mesh::signedVolume(in);
        EXPECT_NEAR(out.volume, v, 0.01 * v) << f;
    }
}

TEST(Voxelize, OpenMeshGivesAnUnsignedBand) {
    const mesh::TriMesh bunny = mesh::readMesh(test::sharedData() / "meshes/bunny/bunny.ply");
    volume::VoxelizeOptions o;
    o.voxelSize = 0.002f;
    const volume::VoxelizeResult r = volume::voxelize(bunny, o);
    EXPECT_FALSE(r.isSigned);
    EXPECT_GT(r.grid->activeVoxelCount(), 0u);
    float lo = 1e30f;
    for (auto it = r.grid->cbeginValueOn(); it; ++it) lo = std::min(lo, *it);
    EXPECT_GE(lo, 0.f) << "an unsigned distance has no negative values";
    EXPECT_THROW(volume::voxelize(mesh::TriMesh{}, o), std::invalid_argument);
}
