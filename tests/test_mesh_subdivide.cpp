// Loop subdivision: closed meshes stay closed with their genus, the volume change shrinks level by
// level (convergence), the limit of an icosahedron approaches a sphere, open meshes keep boundaries.
#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

#include <gtest/gtest.h>

#include "mesh/io.h"
#include "mesh/primitives.h"
#include "mesh/subdivide.h"
#include "test_util.h"

using namespace isoforge;

TEST(Loop, ConvergesKeepsGenusAndStaysClosed) {
    for (const auto& [name, base, genus] :
         {std::tuple{"cube", mesh::makeCube(1), 0LL}, std::tuple{"torus", mesh::makeTorus(12), 1LL},
          std::tuple{"vase", mesh::readMesh(test::sharedData() / "meshes/vase/Vase.stl"), 0LL}}) {
        mesh::TriMesh m = base;
        double previousVolume = mesh::signedVolume(m), previousChange = 1e300;
        for (int level = 1; level <= 3; ++level) {
            m = mesh::loopSubdivide(m);
            const auto r = test::expectClosedSurface(m, std::string(name) + " level " + std::to_string(level));
            EXPECT_EQ(r.genus().value_or(-1), genus) << name;
            EXPECT_EQ(m.triangles.size(), base.triangles.size() << (2 * level));
            const double change = std::abs(r.volume - previousVolume);
            EXPECT_LT(change, previousChange) << name << " level " << level << ": not converging";
            previousChange = change;
            previousVolume = r.volume;
        }
    }
}

TEST(Loop, OpenMeshesKeepTheirBoundary) {
    // A square of two triangles stays flat and its boundary stays on the square's edges' curve.
    mesh::TriMesh quad;
    quad.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    quad.triangles = {{0, 1, 2}, {0, 2, 3}};
    const mesh::TriMesh s = mesh::loopSubdivide(mesh::loopSubdivide(quad));
    EXPECT_EQ(s.triangles.size(), 32u);
    for (const auto& p : s.positions) EXPECT_FLOAT_EQ(p.z, 0.f);
    EXPECT_EQ(mesh::check(s).boundaryEdges, 16u);
    EXPECT_THROW(mesh::loopSubdivide([] {
                     mesh::TriMesh fin;
                     fin.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
                     fin.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
                     return fin;
                 }()),
                 std::invalid_argument);
}

TEST(Butterfly, InterpolatesKeepsOriginalVerticesAndStaysClosed) {
    // The seed's example: a cube rounded by three levels. Original vertices never move; the surface
    // stays closed with genus 0; an icosahedron's limit (valence 5 everywhere at first) approaches
    // a sphere through its vertices.
    for (const auto& [name, base, genus] :
         {std::tuple{"cube", mesh::makeCube(1), 0LL}, std::tuple{"icosphere", mesh::makeIcosphere(0), 0LL},
          std::tuple{"torus", mesh::makeTorus(12), 1LL}}) {
        mesh::TriMesh m = base;
        for (int level = 1; level <= 3; ++level) {
            const mesh::TriMesh next = mesh::butterflySubdivide(m);
            for (std::size_t i = 0; i < m.positions.size(); ++i)
                ASSERT_EQ(next.positions[i], m.positions[i]) << name << ": vertex " << i << " moved";
            m = next;
            const auto r = test::expectClosedSurface(m, std::string(name) + " level " + std::to_string(level));
            EXPECT_EQ(r.genus().value_or(-1), genus) << name;
        }
    }
    mesh::TriMesh ico = mesh::makeIcosphere(0);
    for (int i = 0; i < 4; ++i) ico = mesh::butterflySubdivide(ico);
    double lo = 1e9, hi = 0;
    for (const auto& p : ico.positions) {
        lo = std::min(lo, double(glm::length(p)));
        hi = std::max(hi, double(glm::length(p)));
    }
    EXPECT_GT(lo / hi, 0.93) << "close to a sphere";
    // Open meshes: the square stays flat, its corners fixed.
    mesh::TriMesh quad;
    quad.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    quad.triangles = {{0, 1, 2}, {0, 2, 3}};
    const mesh::TriMesh s = mesh::butterflySubdivide(quad);
    for (const auto& p : s.positions) EXPECT_FLOAT_EQ(p.z, 0.f);
    for (int i = 0; i < 4; ++i)
        EXPECT_EQ(s.positions[static_cast<std::size_t>(i)], quad.positions[static_cast<std::size_t>(i)]);
}
