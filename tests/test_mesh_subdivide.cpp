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

TEST(Loop, CreasesKeepACubesEdgesAndCorners) {
    const mesh::TriMesh cube = mesh::makeCube(1);  // 8 vertices, 12 triangles, edges of 90 degrees
    for (int levels = 1; levels <= 3; ++levels) {
        const mesh::TriMesh creased = mesh::loopSubdivide(cube, levels, 30.0);
        test::expectClosedSurface(creased, "creased cube, " + std::to_string(levels) + " levels");
        // Every vertex stays in the cube, and the cube's 12 edges, each now 2^levels segments, stay
        // straight on the cube's edges: 8 corners + 12 (2^levels - 1) vertices with two coordinates
        // at +-0.5.
        std::size_t onEdges = 0, corners = 0;
        for (const glm::vec3& p : creased.positions) {
            int atFace = 0;
            for (int c = 0; c < 3; ++c) {
                ASSERT_LE(std::abs(p[c]), 0.5f + 1e-6f);
                atFace += std::abs(std::abs(p[c]) - 0.5f) < 1e-6f;
            }
            onEdges += atFace >= 2;
            corners += atFace == 3;
        }
        EXPECT_EQ(corners, 8u);
        EXPECT_EQ(onEdges, 8u + 12u * ((1u << levels) - 1u)) << levels << " levels";
        // Without creases the cube shrinks towards a blob and no vertex stays on its edges.
        const mesh::TriMesh smooth = mesh::loopSubdivide(cube, levels);
        EXPECT_LT(mesh::signedVolume(smooth), mesh::signedVolume(creased));
        for (const glm::vec3& p : smooth.positions) EXPECT_LT(glm::length(p), std::sqrt(0.75f) - 1e-3f);
    }
    // A crease angle above the cube's 90 degrees marks nothing: the same as no creases.
    const mesh::TriMesh wide = mesh::loopSubdivide(cube, 2, 120.0), none = mesh::loopSubdivide(cube, 2);
    EXPECT_EQ(wide.positions, none.positions);
}

TEST(CurveSubdivision, ChaikinCutsCornersAndFourPointInterpolates) {
    const std::vector<glm::vec2> square = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    const auto c1 = mesh::chaikin(square, 1);
    ASSERT_EQ(c1.size(), 8u);
    EXPECT_EQ(c1[0], glm::vec2(0.25f, 0.f));
    EXPECT_EQ(c1[1], glm::vec2(0.75f, 0.f));
    EXPECT_EQ(c1[7], glm::vec2(0.f, 0.25f));
    // The limit is the closed quadratic B-spline of the square: inside it, touching each side's middle.
    const auto c6 = mesh::chaikin(square, 6);
    EXPECT_EQ(c6.size(), 4u << 6);
    for (const glm::vec2& p : c6) EXPECT_TRUE(p.x >= 0 && p.x <= 1 && p.y >= 0 && p.y <= 1);
    float nearest = 1;
    for (const glm::vec2& p : c6) nearest = std::min(nearest, glm::length(p - glm::vec2(0.5f, 0.f)));
    EXPECT_LT(nearest, 0.01f);
    // Open polylines keep their ends.
    const auto open = mesh::chaikin({{0, 0}, {1, 1}, {2, 0}}, 3, false);
    EXPECT_EQ(open.front(), glm::vec2(0, 0));
    EXPECT_EQ(open.back(), glm::vec2(2, 0));

    // 4-point on a regular 12-gon: the old points are kept, the new ones land close to the circle.
    std::vector<glm::vec2> gon;
    for (int i = 0; i < 12; ++i)
        gon.emplace_back(std::cos(2 * float(M_PI) * float(i) / 12), std::sin(2 * float(M_PI) * float(i) / 12));
    const auto f3 = mesh::fourPoint(gon, 3);
    ASSERT_EQ(f3.size(), 12u << 3);
    for (std::size_t i = 0; i < gon.size(); ++i) EXPECT_EQ(f3[8 * i], gon[i]) << "old point " << i << " moved";
    double worst = 0;
    for (const glm::vec2& p : f3) worst = std::max(worst, std::abs(double(glm::length(p)) - 1.0));
    EXPECT_LT(worst, 2e-3);  // a 12-gon's chords are 3.4% inside the circle at their middles
    // On a straight line, 4-point keeps new points on the line (it reproduces cubics).
    const auto line = mesh::fourPoint({{0, 0}, {1, 2}, {2, 4}, {3, 6}}, 2, false);
    for (const glm::vec2& p : line) EXPECT_NEAR(p.y, 2 * p.x, 1e-5f);
    EXPECT_EQ(line.back(), glm::vec2(3, 6));
}
