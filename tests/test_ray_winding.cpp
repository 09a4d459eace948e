#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include <glm/geometric.hpp>

#include <gtest/gtest.h>

#include "csg/ray_winding.h"
#include "csg/shapes.h"
#include "mesh/io.h"
#include "test_util.h"

namespace isoforge {
namespace {

/// A hierarchy of two leaves under one root, split by triangle index: enough to exercise the traversal.
struct TwoLeafBvh {
    std::vector<csg::MeshBvhNode> nodes;
    std::vector<std::uint32_t> order;
    explicit TwoLeafBvh(const mesh::TriMesh& m) {
        order.resize(m.triangles.size());
        std::iota(order.begin(), order.end(), 0u);
        auto box = [&](std::uint32_t from, std::uint32_t to) {
            csg::MeshBvhNode n{glm::vec3(1e30f), glm::vec3(-1e30f), from, to - from};
            for (std::uint32_t i = from; i < to; ++i)
                for (int k = 0; k < 3; ++k) {
                    n.lo = glm::min(n.lo, m.positions[m.triangles[i][k]]);
                    n.hi = glm::max(n.hi, m.positions[m.triangles[i][k]]);
                }
            return n;
        };
        const auto n = static_cast<std::uint32_t>(m.triangles.size()), half = n / 2;
        nodes = {box(0, n), box(0, half), box(half, n)};
        nodes[0].first = 1;
        nodes[0].count = 0;
    }
    csg::MeshBvhView view(const mesh::TriMesh& m) const { return {nodes, order, m.triangles, m.positions}; }
};

TEST(RayWinding, CrossingsCountTheSolidAngleWindingNumber) {
    // The cow (closed; its head folds through itself, so the winding number reaches 2 in places): the
    // signed crossings of a ray are the winding number wherever the ray is not refused, at points near and on
    // the surface's vertices' planes, and most rays are not refused.
    const mesh::TriMesh cow = mesh::readMesh(test::sourceDir() / "data/cow.obj");
    const TwoLeafBvh bvh(cow);
    std::mt19937 rng(7);
    std::normal_distribution<float> jitter(0.f, 0.01f);
    std::size_t counted = 0, refused = 0, inside = 0;
    for (std::size_t v = 0; v < cow.positions.size(); v += 53) {
        for (int j = 0; j < 4; ++j) {
            // j = 0: on the vertex's own plane along x (a grid sample lying on a vertex's coordinate).
            glm::vec3 q = cow.positions[v] + glm::vec3(j == 0 ? 0.f : jitter(rng), jitter(rng), jitter(rng));
            const auto in = csg::insideByRays(bvh.view(cow), q);
            const double w = test::windingNumber(cow, glm::dvec3(q));
            if (!in) {
                ++refused;
                continue;
            }
            ++counted;
            inside += *in;
            if (std::abs(std::abs(w) - std::round(std::abs(w))) < 1e-3) {  // off the surface
                EXPECT_EQ(*in, std::abs(w) > 0.5) << "vertex " << v << " winding " << w;
            }
        }
    }
    EXPECT_GT(counted, 200u);
    EXPECT_LT(refused, counted / 50 + 1);
    EXPECT_GT(inside, counted / 5);
    EXPECT_LT(inside, counted - counted / 5);
}

TEST(RayWinding, RaysThroughEdgesVerticesAndFromTheSurfaceAreRefused) {
    // A unit cube, its faces split along a diagonal.
    mesh::TriMesh cube;
    for (int c = 0; c < 8; ++c) cube.positions.emplace_back(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    for (const glm::ivec4 f : {glm::ivec4(0, 2, 3, 1), glm::ivec4(4, 5, 7, 6), glm::ivec4(0, 1, 5, 4),
                               glm::ivec4(2, 6, 7, 3), glm::ivec4(0, 4, 6, 2), glm::ivec4(1, 3, 7, 5)}) {
        cube.triangles.emplace_back(f[0], f[1], f[2]);
        cube.triangles.emplace_back(f[0], f[2], f[3]);
    }
    const TwoLeafBvh bvh(cube);
    const glm::dvec3 centre(0.5), oblique = glm::normalize(glm::dvec3(0.3, 0.2, 0.9));
    ASSERT_TRUE(csg::windingAlongRay(bvh.view(cube), centre, oblique).has_value());
    EXPECT_EQ(std::abs(*csg::windingAlongRay(bvh.view(cube), centre, oblique)), 1);
    EXPECT_EQ(*csg::windingAlongRay(bvh.view(cube), glm::dvec3(2.0, 0.5, 0.5), oblique), 0);
    // Any ray from inside leaves once; the faces turned over, the opposite sign.
    EXPECT_EQ(*csg::windingAlongRay(bvh.view(cube), centre, oblique),
              *csg::windingAlongRay(bvh.view(cube), centre, -oblique));
    mesh::TriMesh flipped = cube;
    for (auto& t : flipped.triangles) std::swap(t.y, t.z);
    EXPECT_EQ(*csg::windingAlongRay(TwoLeafBvh(flipped).view(flipped), centre, oblique),
              -*csg::windingAlongRay(bvh.view(cube), centre, oblique));
    EXPECT_FALSE(csg::windingAlongRay(bvh.view(cube), centre, glm::normalize(glm::dvec3(1.0))));            // a vertex
    EXPECT_FALSE(csg::windingAlongRay(bvh.view(cube), centre, glm::normalize(glm::dvec3(1.0, 1.0, 0.0))));  // an edge
    // Through a face's diagonal (an edge inside the face).
    EXPECT_FALSE(csg::windingAlongRay(bvh.view(cube), glm::dvec3(0.5, 0.5, 0.2), glm::dvec3(0.0, 0.0, 1.0)));
    EXPECT_FALSE(csg::windingAlongRay(bvh.view(cube), glm::dvec3(0.3, 0.6, 1.0), oblique));  // q on a face
    // In a face's plane, off the cube: refused (the ray runs along the face's plane).
    EXPECT_FALSE(csg::windingAlongRay(bvh.view(cube), glm::dvec3(-1.0, 0.5, 1.0), glm::dvec3(1.0, 0.0, 0.0)));
}

TEST(RayWinding, OpenMeshFieldSignsAsItsCappedSolid) {
    // A cube without its top (an open mesh, capped for the winding number): inside it is inside, and the
    // signs of points crowding the open rim agree with the solid angles of the capped cube.
    std::vector<glm::vec3> p;
    for (int c = 0; c < 8; ++c) p.emplace_back(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    std::vector<glm::uvec3> t;
    for (const glm::ivec4 f : {glm::ivec4(0, 2, 3, 1), glm::ivec4(0, 1, 5, 4), glm::ivec4(2, 6, 7, 3),
                               glm::ivec4(0, 4, 6, 2), glm::ivec4(1, 3, 7, 5)}) {
        t.emplace_back(f[0], f[1], f[2]);
        t.emplace_back(f[0], f[2], f[3]);
    }
    auto field = csg::makeTriangleMeshField(p, t);
    for (int i = 0; i <= 20; ++i)
        for (int k = 0; k <= 20; ++k) {
            const glm::vec3 q(0.05f * i, 0.37f, 0.9f + 0.01f * k);
            const bool in = q.x > 0.f && q.x < 1.f && q.z < 1.f;
            if (std::abs(q.x) < 1e-6f || std::abs(q.x - 1.f) < 1e-6f || std::abs(q.z - 1.f) < 1e-6f) continue;
            EXPECT_EQ(field->value(q) < 0.f, in) << q.x << " " << q.z;
        }
}

}  // namespace
}  // namespace isoforge
