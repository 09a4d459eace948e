// Per-side normals at creases (mesh/crease_normals.h): which vertices split, the normals each side gets,
// and that the surface is unchanged (closed by position).
#include <cmath>

#include <tbb/global_control.h>
#include <glm/geometric.hpp>

#include <gtest/gtest.h>

#include "mesh/check.h"
#include "mesh/crease_normals.h"
#include "mesh/primitives.h"

using namespace isoforge;

namespace {
/// One normal per vertex: the mean of its triangles' unit normals (what a smooth-shaded mesh carries).
void averageNormals(mesh::TriMesh& m) {
    m.normals.assign(m.positions.size(), glm::vec3(0.f));
    for (const glm::uvec3& t : m.triangles) {
        const glm::vec3 n =
            glm::normalize(glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x]));
        for (int k = 0; k < 3; ++k) m.normals[t[k]] += n;
    }
    for (glm::vec3& n : m.normals) n = glm::normalize(n);
}
}  // namespace

TEST(CreaseNormals, ACubesCornersAndEdgesGetOneNormalPerFace) {
    // A cube whose faces are 3 x 3 grids: its 8 corners have 3 faces each, the 2 inner vertices of each of its
    // 12 edges have 2; face interiors have 1. Every side's normal is its face's own.
    mesh::TriMesh m = mesh::makeCube(3);
    averageNormals(m);
    m.colors.assign(m.positions.size(), glm::vec3(0.2f, 0.4f, 0.6f));
    const mesh::TriMesh before = m;
    const std::size_t added = mesh::splitNormalsAtCreases(m, 30.0);
    EXPECT_EQ(added, 8u * 2 + 12u * 2 * 1);
    ASSERT_EQ(m.positions.size(), before.positions.size() + added);
    ASSERT_EQ(m.normals.size(), m.positions.size());
    ASSERT_EQ(m.colors.size(), m.positions.size());
    ASSERT_EQ(m.triangles.size(), before.triangles.size());
    for (std::size_t t = 0; t < m.triangles.size(); ++t) {
        const glm::uvec3 &a = m.triangles[t], &b = before.triangles[t];
        const glm::vec3 face =
            glm::normalize(glm::cross(m.positions[a.y] - m.positions[a.x], m.positions[a.z] - m.positions[a.x]));
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(m.positions[a[k]], before.positions[b[k]]) << "the surface is unchanged";
            EXPECT_EQ(m.colors[a[k]], before.colors[b[k]]);
            EXPECT_GT(glm::dot(m.normals[a[k]], face), 0.9999f) << "triangle " << t;
        }
    }
    // Closed by position, open by index.
    const mesh::MeshReport welded = mesh::check(m, {.weldByPosition = true});
    EXPECT_TRUE(welded.isValidClosedSurface()) << welded.toString();
    EXPECT_EQ(welded.weldedVertices, added);
    EXPECT_GT(mesh::check(m).boundaryEdges, 0u);
    // Faces more than 90 degrees apart only: nothing splits on a cube.
    mesh::TriMesh wide = before;
    EXPECT_EQ(mesh::splitNormalsAtCreases(wide, 90.5), 0u);
    EXPECT_EQ(wide.normals, before.normals);
}

TEST(CreaseNormals, SmoothSurfacesAndMeshesWithoutNormalsAreLeftAlone) {
    mesh::TriMesh sphere = mesh::makeIcosphere(3);
    averageNormals(sphere);
    const mesh::TriMesh before = sphere;
    EXPECT_EQ(mesh::splitNormalsAtCreases(sphere, 30.0), 0u);
    EXPECT_EQ(sphere.normals, before.normals);
    EXPECT_EQ(sphere.triangles, before.triangles);
    mesh::TriMesh bare = mesh::makeCube(2);  // no normals: nothing to split
    EXPECT_EQ(mesh::splitNormalsAtCreases(bare, 30.0), 0u);
    mesh::TriMesh all = before;  // 180 degrees: one normal per vertex
    EXPECT_EQ(mesh::splitNormalsAtCreases(all, 180.0), 0u);
}

TEST(CreaseNormals, ACylinderSplitsAtItsRimsOnlyTheSameAtAnyThreadCount) {
    // 48 sides (7.5 degrees apart): the side stays smooth, the rims split (each rim vertex: side and cap).
    mesh::TriMesh reference;
    for (int threads : {1, 2, 3}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        mesh::TriMesh m = mesh::makeCylinder(48);
        averageNormals(m);
        const std::size_t n = m.positions.size();
        const std::size_t added = mesh::splitNormalsAtCreases(m, 30.0);
        if (threads == 1) {
            EXPECT_GE(added, 2u * 48) << "every rim vertex, top and bottom, of " << n;
            for (std::size_t v = n; v < m.positions.size(); ++v)  // copies: on a rim
                EXPECT_NEAR(std::abs(m.positions[v].z), 0.5f, 1e-6f);
            EXPECT_TRUE(mesh::check(m, {.weldByPosition = true}).isValidClosedSurface());
            reference = m;
            continue;
        }
        EXPECT_EQ(m.positions, reference.positions) << threads << " threads";
        EXPECT_EQ(m.normals, reference.normals) << threads << " threads";
        EXPECT_EQ(m.triangles, reference.triangles) << threads << " threads";
    }
}
