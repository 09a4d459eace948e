// The half-edge structure: rings and valences, boundary loops, flips and splits, and refusal of
// non-manifold input.
#include <algorithm>
#include <random>

#include <gtest/gtest.h>

#include "mesh/halfedge.h"
#include "mesh/io.h"
#include "mesh/primitives.h"
#include "test_util.h"

using namespace isoforge;
using mesh::HalfEdgeMesh;

TEST(HalfEdge, RingsValencesAndFacesAround) {
    const HalfEdgeMesh h(mesh::makeIcosphere(2));
    std::size_t five = 0, six = 0;
    for (std::uint32_t v = 0; v < h.vertexCount(); ++v) {
        const auto ring = h.oneRing(v);
        EXPECT_EQ(h.facesAround(v).size(), ring.size());
        EXPECT_FALSE(h.isBoundaryVertex(v));
        five += ring.size() == 5;
        six += ring.size() == 6;
        // Consecutive ring vertices are themselves neighbours (the ring is in rotation order).
        for (std::size_t i = 0; i < ring.size(); ++i) {
            const auto r2 = h.oneRing(ring[i]);
            EXPECT_NE(std::find(r2.begin(), r2.end(), ring[(i + 1) % ring.size()]), r2.end());
        }
    }
    EXPECT_EQ(five, 12u);  // the icosahedron's own vertices
    EXPECT_EQ(five + six, h.vertexCount());
    EXPECT_TRUE(h.boundaryLoops().empty());
    EXPECT_EQ(h.halfEdgeCount(), 3 * h.faceCount());
}

TEST(HalfEdge, BoundaryLoopsOfOpenMeshes) {
    // A cube without its top face: one loop of four vertices; the bunny's holes: real data.
    mesh::TriMesh cube = mesh::makeCube(1);
    cube.triangles.erase(cube.triangles.begin() + 2, cube.triangles.begin() + 4);  // the +x face
    const HalfEdgeMesh h(cube);
    const auto loops = h.boundaryLoops();
    ASSERT_EQ(loops.size(), 1u);
    EXPECT_EQ(loops[0].size(), 4u);
    for (std::uint32_t v : loops[0]) {
        EXPECT_TRUE(h.isBoundaryVertex(v));
        EXPECT_EQ(h.facesAround(v).size() + 1, h.oneRing(v).size());  // an open fan
    }
    const HalfEdgeMesh bunny(mesh::readMesh(test::sharedData() / "meshes/bunny/bunny.ply"));
    std::size_t edges = 0;
    for (const auto& l : bunny.boundaryLoops()) edges += l.size();
    EXPECT_EQ(edges, 223u);  // `isoforge check` reports 223 boundary edges
}

TEST(HalfEdge, FlipsAndSplitsKeepAClosedManifold) {
    HalfEdgeMesh h(mesh::makeIcosphere(1));
    const std::size_t v0 = h.vertexCount(), f0 = h.faceCount();
    const std::uint32_t m = h.split(0);
    EXPECT_EQ(m, v0);
    EXPECT_EQ(h.faceCount(), f0 + 2);
    EXPECT_EQ(h.valence(m), 4u);
    test::expectClosedSurface(h.toTriMesh(), "after split");
    // Flip an edge at the new vertex: still closed and manifold, same face count.
    std::uint32_t edge = 0;
    while (h.halfEdge(edge).to != m) ++edge;
    EXPECT_TRUE(h.flip(edge));
    EXPECT_EQ(h.faceCount(), f0 + 2);
    test::expectClosedSurface(h.toTriMesh(), "after flip");
    // A boundary edge cannot flip.
    mesh::TriMesh quad;
    quad.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    quad.triangles = {{0, 1, 2}, {0, 2, 3}};
    HalfEdgeMesh q(quad);
    EXPECT_FALSE(q.flip(0));                            // 0 -> 1 is on the boundary
    EXPECT_TRUE(q.flip(2));                             // 2 -> 0, the diagonal
    EXPECT_NEAR(mesh::area(q.toTriMesh()), 1.0, 1e-6);  // the same square, other diagonal
}

TEST(HalfEdge, RefusesWhatItCannotHold) {
    mesh::TriMesh fin;  // three triangles on one edge
    fin.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
    fin.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
    EXPECT_THROW(HalfEdgeMesh{fin}, std::invalid_argument);
    mesh::TriMesh flipped = mesh::makeIcosphere(0);
    std::swap(flipped.triangles[3].y, flipped.triangles[3].z);  // inconsistent orientation
    EXPECT_THROW(HalfEdgeMesh{flipped}, std::invalid_argument);
    // Two tetrahedra sharing one vertex: two fans at it.
    mesh::TriMesh bow;
    bow.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
    bow.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}, {0, 4, 5}, {0, 6, 4}, {0, 5, 6}, {4, 6, 5}};
    try {
        HalfEdgeMesh b(bow);
        FAIL() << "a pinched vertex must be refused";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("several fans"), std::string::npos) << e.what();
    }
}

TEST(HalfEdge, LocalFlipsAndSplitsMatchARebuild) {
    // Thousands of random flips and splits on a closed mesh and an open one, applied locally; after
    // each batch the structure must equal one built from scratch from the same triangles.
    for (const mesh::TriMesh& start :
         {mesh::makeIcosphere(2), mesh::readMesh(test::sharedData() / "meshes/bunny/bunny.ply")}) {
        mesh::HalfEdgeMesh h(start);
        std::mt19937 rng(5);
        for (int batch = 0; batch < 6; ++batch) {
            for (int i = 0; i < 300; ++i) {
                const auto e = static_cast<std::uint32_t>(rng() % h.halfEdgeCount());
                if (rng() % 3 == 0)
                    h.split(e);
                else
                    h.flip(e);
            }
            const mesh::TriMesh now = h.toTriMesh();
            const mesh::HalfEdgeMesh fresh(now);  // throws if the local edits broke manifoldness
            ASSERT_EQ(fresh.halfEdgeCount(), h.halfEdgeCount());
            for (std::uint32_t e = 0; e < h.halfEdgeCount(); ++e) {
                ASSERT_EQ(h.halfEdge(e).to, fresh.halfEdge(e).to) << "half-edge " << e;
                ASSERT_EQ(h.halfEdge(e).twin, fresh.halfEdge(e).twin) << "half-edge " << e;
            }
            for (std::uint32_t v = 0; v < h.vertexCount(); ++v) {
                ASSERT_EQ(h.isBoundaryVertex(v), fresh.isBoundaryVertex(v)) << "vertex " << v;
                auto r1 = h.oneRing(v), r2 = fresh.oneRing(v);
                if (!h.isBoundaryVertex(v)) {  // interior rings may start anywhere
                    std::sort(r1.begin(), r1.end());
                    std::sort(r2.begin(), r2.end());
                }
                ASSERT_EQ(r1, r2) << "vertex " << v;
            }
            EXPECT_EQ(h.boundaryLoops().size(), fresh.boundaryLoops().size());
        }
        const mesh::MeshReport r = mesh::check(h.toTriMesh());
        EXPECT_EQ(r.nonManifoldEdges + r.misorientedEdges, 0u);
    }
}
