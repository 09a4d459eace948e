// Triangle strips on the bundled real meshes and on primitives: they expand back to exactly the same
// oriented triangles and send fewer than 3 vertices per triangle.
#include <gtest/gtest.h>

#include "mesh/io.h"
#include "mesh/primitives.h"
#include "mesh/strips.h"
#include "test_util.h"

using namespace isoforge;

TEST(Strips, ExpandBackExactlyAndBeatThreeVerticesPerTriangle) {
    std::vector<std::pair<std::string, mesh::TriMesh>> meshes;
    for (const char* f : {"meshes/cow/cow.obj", "meshes/bunny/bunny.ply", "meshes/vase/Vase.stl"})
        meshes.emplace_back(f, mesh::readMesh(test::sharedData() / f));
    meshes.emplace_back("torus 64", mesh::makeTorus(64));
    meshes.emplace_back("icosphere 4", mesh::makeIcosphere(4));
    for (const auto& [name, m] : meshes) {
        const mesh::Strips s = mesh::makeStrips(m);
        EXPECT_TRUE(mesh::sameTriangles(mesh::expandStrips(s), m.triangles)) << name;
        EXPECT_LT(s.verticesPerTriangle(), 2.0) << name;  // measured 1.5-1.7 (3 for a plain list)
        EXPECT_GT(s.stripCount, 0u) << name;
    }
    // A single triangle: one strip of three vertices; sameTriangles notices a flipped triangle.
    mesh::TriMesh one;
    one.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    one.triangles = {{0, 1, 2}};
    const mesh::Strips s = mesh::makeStrips(one);
    EXPECT_DOUBLE_EQ(s.verticesPerTriangle(), 3.0);
    EXPECT_TRUE(mesh::sameTriangles(mesh::expandStrips(s), {{1, 2, 0}}));
    EXPECT_FALSE(mesh::sameTriangles(mesh::expandStrips(s), {{0, 2, 1}}));
}
