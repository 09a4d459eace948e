// hull() and minkowski() as OpenSCAD computes them: on the children's polyhedra (OpenSCAD's own
// vertices for faceted primitives), with regularized differences, in 2D by Clipper; the convex
// polytope field they make.
#include <cmath>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "csg/parts.h"
#include "csg/polytope.h"
#include "csg/scene.h"
#include "csg/surface.h"
#include "mesh/check.h"
#include "mesh/convex_hull.h"
#include "mesh/io.h"

using namespace isoforge;

namespace {
std::string warnings(const csg::Scene& s) {
    std::string all;
    for (const auto& w : s.warnings) all += w.loc.toString() + ": " + w.message + "\n";
    return all;
}
}  // namespace

TEST(ConvexHull, VerticesOnlyAndFlatSetsEmpty) {
    std::vector<glm::dvec3> p;
    for (int i = 0; i < 8; ++i) p.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
    p.emplace_back(0.5, 0.5, 0.5);  // inside
    p.emplace_back(0.5, 0.0, 0.0);  // on an edge
    const mesh::ConvexHull h = mesh::convexHull(p);
    EXPECT_NEAR(mesh::volume(h), 1.0, 1e-12);
    EXPECT_EQ(h.triangles.size(), 12u);
    const std::vector<glm::dvec3> flat{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0.3, 0.2, 0}};
    EXPECT_TRUE(mesh::convexHull(flat).empty());
    EXPECT_TRUE(mesh::convexHull(std::vector<glm::dvec3>{{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {3, 3, 3}}).empty());
}

TEST(ConvexPolytope, ExactInsideConservativeBoundsAndPrunedAlike) {
    std::mt19937 rng(7);
    std::normal_distribution<double> g;
    std::vector<glm::dvec3> p;
    for (int i = 0; i < 400; ++i) {
        const glm::dvec3 v(g(rng), g(rng), g(rng));
        p.push_back(v / glm::length(v) * 2.0);  // points on a sphere of radius 2: hundreds of faces
    }
    const auto f = csg::makeConvexPolytope(mesh::convexHull(p));
    EXPECT_LT(f->value(glm::vec3(0.f)), -1.8f);  // the inscribed radius of a polytope of 400 points on it
    EXPECT_GE(f->value(glm::vec3(0.f)), -2.f);
    EXPECT_GT(f->value(glm::vec3(2.1f, 0, 0)), 0.f);
    std::uniform_real_distribution<float> u(-3.f, 3.f), w(0.05f, 0.6f);
    for (int b = 0; b < 200; ++b) {
        const glm::vec3 lo(u(rng), u(rng), u(rng));
        const implicit::Box3 box{lo, lo + glm::vec3(w(rng), w(rng), w(rng))};
        const implicit::Interval range = f->bound(box);
        const implicit::FieldPtr s = implicit::simplified(f, box);
        for (int k = 0; k < 20; ++k) {
            const glm::vec3 q = box.min + (box.max - box.min) * glm::vec3(k % 3 / 2.f, k % 5 / 4.f, k % 7 / 6.f);
            const float v = f->value(q);
            EXPECT_TRUE(range.lo <= v && v <= range.hi) << v << " outside the bound of its box";
            EXPECT_EQ(s->value(q), v) << "pruned planes changed a value";
        }
    }
}

TEST(ConvexPolytope, SliversOfPointsARoundingErrorApartCutNothingOff) {
    // Summed and clipped points come in clusters a few ulps apart: their hull has sliver triangles whose
    // normals mean nothing. Only those planes are checked against every point (csg/polytope.cpp); no plane
    // may cut a point off, and the polytope must still hug the points.
    std::mt19937 rng(11);
    std::normal_distribution<double> g;
    for (const double apart : {1e-15, 1e-13, 1e-11}) {
        std::vector<glm::dvec3> p;
        for (int i = 0; i < 300; ++i) {
            const glm::dvec3 v(g(rng), g(rng), g(rng));
            const glm::dvec3 q = v / glm::length(v) * 3.0 + glm::dvec3(10, -4, 2);
            p.push_back(q);
            for (int k = 0; k < 3; ++k) p.push_back(q + apart * glm::dvec3(g(rng), g(rng), g(rng)));
        }
        const mesh::ConvexHull h = mesh::convexHull(p);
        const auto f = csg::makeConvexPolytope(h);
        for (const glm::dvec3& q : p) {
            EXPECT_LE(f->value(glm::vec3(q)), 1e-5f) << "a point cut off, " << apart << " apart";
            const glm::dvec3 out = glm::dvec3(10, -4, 2) + (q - glm::dvec3(10, -4, 2)) * 1.01;
            EXPECT_GT(f->value(glm::vec3(out)), 0.f) << "a point 1% out is inside, " << apart << " apart";
        }
    }
}

TEST(OpenScadHull, HullsOfPrimitivesAndOfDifferences) {
    const auto s = csg::parseScene("hull() { cube(1); translate([3, 0, 0]) cube(1); }", "h.isf");
    EXPECT_LT(s.root->value(glm::vec3(2.f, 0.5f, 0.5f)), 0.f);  // the gap is filled
    EXPECT_NEAR(s.root->value(glm::vec3(2.f, 0.5f, 0.5f)), -0.5f, 1e-5f);
    EXPECT_NEAR(s.root->bounds().max.x, 4.f, 1e-4f);
    // OpenSCAD's $fn = 4 cylinders intersected: the hull is two pyramids on a 4 x 4 square (21.33).
    const auto oct = csg::parseScene(R"(
        hull() intersection() {
            rotate([90, 0, 0]) cylinder(r = 2, h = 4, $fn = 4, center = true);
            cylinder(r = 2, h = 4, $fn = 4, center = true);
        })",
                                     "o.isf");
    EXPECT_NEAR(oct.root->value(glm::vec3(0, 2, 2)), 0.f, 1e-5f);  // a vertex of the hull
    EXPECT_NEAR(oct.root->value(glm::vec3(1.f, 0, 0)), -1.f / std::sqrt(2.f), 1e-5f);
    // The hull of a difference is the hull of what is left: the first child, moved down by what
    // the second takes off its top.
    const auto cut = csg::parseScene("hull() difference() { cube(2); translate([-1, -1, 1]) cube(4); }", "c.isf");
    EXPECT_NEAR(cut.root->bounds().max.z, 1.f, 1e-4f);
    // Found by fuzz_scene (tests/data/fuzz/scene/): a 97-gon frustum less a 96-gon cylinder through it is
    // covered by overlapping pieces, 124,640 corners of which 18,868 differ, and CGAL's hull of them all
    // took 1.9 s (20 s under ASan). The hull takes each point once. What is left is the frustum above
    // z0, where its radius (1 at the bottom, 10 at the top) passes 5: its hull is the frustum cut there
    // (within the 96-gon's deviation from a circle, 5 (1 - cos(pi / 96)) in radius).
    const auto frustum = csg::parseScene("hull() cylinder(h = 4, r1 = 1, r2 = 10, center = true, $fn = 97);", "f.isf");
    const auto holed = csg::parseScene(R"(
        hull() difference() {
            cylinder(h = 4, r1 = 1, r2 = 10, center = true, $fn = 97);
            cylinder(h = 5, r = 5, center = true, $fn = 96);
        })",
                                       "d.isf");
    const float z0 = -2.f + 4.f * 4.f / 9.f;
    for (const glm::vec3 q : {glm::vec3(0.f), glm::vec3(3.f, 1.f, 0.5f), glm::vec3(-8.f, 2.f, 1.9f), glm::vec3(0, 0, 3),
                              glm::vec3(0, 0, -1)})
        EXPECT_NEAR(holed.root->value(q), std::max(frustum.root->value(q), z0 - q.z), 0.003f)
            << q.x << " " << q.y << " " << q.z;
    // A union of one child is that child, with its own geometry.
    const auto one = csg::parseScene("hull() union() { cube(1); }", "u.isf");
    EXPECT_NEAR(one.root->value(glm::vec3(0.5f)), -0.5f, 1e-5f);
    // Nothing that spans a solid: dropped with OpenSCAD's warning, as the zero-height cylinders of its issue 990.
    const auto flat = csg::parseScene("hull() { cylinder(h = 0); cylinder(h = 0); }", "f.isf");
    EXPECT_TRUE(flat.root->bounds().isEmpty());
    EXPECT_NE(warnings(flat).find("hull()"), std::string::npos) << warnings(flat);
}

TEST(OpenScadHull, MinkowskiSumsOfConvexAndNonConvexObjects) {
    // Boxes: the sum of a 2-cube and a centred 1-cube is a 3-cube from -0.5.
    const auto box = csg::parseScene("minkowski() { cube(2); cube(1, center = true); }", "m.isf");
    EXPECT_NEAR(box.root->value(glm::vec3(1.f)), -1.5f, 1e-5f);
    EXPECT_NEAR(box.root->bounds().min.x, -0.5f, 1e-4f);
    EXPECT_NEAR(box.root->bounds().max.z, 2.5f, 1e-4f);
    // An L-shaped difference (a notch through its whole height) grown by a centred 1-cube: the
    // notch shrinks by 0.5, and no floor is left where it was (regularized: the faces the notch
    // shares with the block are not boundary of what is left).
    const auto l = csg::parseScene(
        "minkowski() { difference() { cube([10, 10, 5]); cube([5, 5, 5]); } cube(1, center = true); }", "l.isf");
    EXPECT_LT(l.root->value(glm::vec3(4.6f, 1.f, 2.f)), 0.f);
    EXPECT_GT(l.root->value(glm::vec3(4.4f, 4.4f, 2.f)), 0.f);
    EXPECT_GT(l.root->value(glm::vec3(1.f, 1.f, -0.4f)), 0.f) << "the notch got a floor";
    EXPECT_GT(l.root->value(glm::vec3(1.f, 1.f, 5.4f)), 0.f) << "the notch got a roof";
    EXPECT_LT(l.root->value(glm::vec3(7.f, 7.f, 5.4f)), 0.f);
    // A non-convex polyhedron (a notched prism) with a cube.
    const auto poly = csg::parseScene(R"(
        minkowski() {
            polyhedron(points = [[0,0,0],[4,0,0],[4,4,0],[2,1,0],[0,4,0],[0,0,1],[4,0,1],[4,4,1],[2,1,1],[0,4,1]],
                       faces = [[4,3,2,1,0],[5,6,7,8,9],[0,1,6,5],[1,2,7,6],[2,3,8,7],[3,4,9,8],[4,0,5,9]]);
            cube(0.2, center = true);
        })",
                                      "p.isf");
    // The notch's sides move in by the cube's support along their normals, 0.1 (2 + 3) / sqrt(13),
    // and its tip up by 0.25.
    EXPECT_LT(poly.root->value(glm::vec3(2.f, 1.2f, 0.5f)), 0.f);
    EXPECT_GT(poly.root->value(glm::vec3(2.f, 1.35f, 0.5f)), 0.f);
    EXPECT_GT(poly.root->value(glm::vec3(2.f, 3.f, 0.5f)), 0.f);  // the notch stays open
    // OpenSCAD leaves out a child that makes nothing (its nullspace-minkowski test: an empty
    // intersection with a cube is the cube).
    const auto null = csg::parseScene(
        "minkowski() { intersection() { translate([-2, 0, 0]) cube(1); translate([2, 0, 0]) cube(1); } cube(); }",
        "n.isf");
    EXPECT_NEAR(null.root->value(glm::vec3(0.5f)), -0.5f, 1e-5f);
    // A difference (or intersection) of one child is the child: its parts are the child's, not made from
    // themselves (fuzz_scene: the sum asked for them and recursed until the stack overflowed).
    for (const char* op : {"difference", "intersection"}) {
        const auto one =
            csg::parseScene(std::string("minkowski() { ") + op + "() { cube(2); } cube(1, center = true); }", "o.isf");
        EXPECT_NEAR(one.root->value(glm::vec3(1.f)), -1.5f, 1e-5f) << op;
    }
}

TEST(OpenScadHull, TwoDimensionalHullAndMinkowskiByClipper) {
    const auto h = csg::parseScene(
        "linear_extrude(1) hull() { circle(1, $fn = 8); translate([4, 0]) square(1, center = true); }", "h.isf");
    EXPECT_LT(h.root->value(glm::vec3(2.5f, 0.5f, 0.5f)), 0.f);
    EXPECT_GT(h.root->value(glm::vec3(2.5f, 0.9f, 0.5f)), 0.f);
    // A square grown by a diamond ($fn = 4 circle): corners cut at 45 degrees.
    const auto m =
        csg::parseScene("linear_extrude(1) minkowski() { square(2, center = true); circle(1, $fn = 4); }", "m.isf");
    EXPECT_LT(m.root->value(glm::vec3(1.9f, 0.f, 0.5f)), 0.f);
    EXPECT_LT(m.root->value(glm::vec3(1.45f, 1.45f, 0.5f)), 0.f);
    EXPECT_GT(m.root->value(glm::vec3(1.55f, 1.55f, 0.5f)), 0.f);
}

TEST(OpenScadHull, IntersectionsWithAChildThatMakesNothingAreEmpty) {
    // OpenSCAD's intersection-tests: an empty render(), an extrusion of nothing, a 2D child.
    for (const char* second : {"render();", "linear_extrude();", "circle(2);"}) {
        const auto s =
            csg::parseScene(std::string("intersection() { cube(4, center = true); ") + second + " }", "i.isf");
        EXPECT_TRUE(s.root->bounds().isEmpty()) << second;
    }
}

TEST(OpenScadHull, RefusedWhereTheGeometryIsNotKnownWithTheReason) {
    try {
        csg::parseScene("\nhull() { rotate_extrude() translate([2, 0]) circle(1); cube(1); }", "r.isf");
        FAIL() << "accepted";
    } catch (const std::exception& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("r.isf:2:1"), std::string::npos) << m;
        EXPECT_NE(m.find("rotate_extrude"), std::string::npos) << m;
    }
    try {
        csg::parseScene(
            "minkowski() { difference() { cube(3); sphere(1); } difference() { cube(3); translate([1,1,1]) cube(1); } "
            "}",
            "n.isf");
        FAIL() << "accepted";
    } catch (const std::exception& e) {
        EXPECT_NE(std::string(e.what()).find("both not convex"), std::string::npos) << e.what();
    }
}

TEST(OpenScadHull, AbsurdSumsAreRefusedBeforeTheWork) {
    for (const char* scene :
         {"minkowski() { sphere(1, $fn = 4000); sphere(1, $fn = 4000); }", "hull() sphere(1, $fn = 10000);"}) {
        try {
            csg::parseScene(scene, "a.isf");
            FAIL() << "accepted " << scene;
        } catch (const std::exception& e) {
            EXPECT_NE(std::string(e.what()).find("more than"), std::string::npos) << e.what();
        }
    }
    // The scene fuzzer lowers the bound on point sums (tests/fuzz_scene.cpp): the same refusal, sooner.
    const std::string small = "minkowski() { sphere(1, $fn = 64); cube(1); }";  // 2,048 x 8 sums
    const std::size_t was = csg::maxMinkowskiSums();
    csg::maxMinkowskiSums() = 1000;
    EXPECT_ANY_THROW(csg::parseScene(small, "b.isf"));
    csg::maxMinkowskiSums() = was;
    EXPECT_NO_THROW(csg::parseScene(small, "b.isf"));
}

TEST(OpenScadSurface, HeightMapsAreClosedSolidsAsOpenScadBuildsThem) {
    const std::string dir = testing::TempDir();
    const std::string dat = dir + "/map.dat";
    {
        std::ofstream f(dat);
        f << "# a comment\n0 1 2\n\n3 4\n5 6 7 8\n";  // a short row: the missing value is 0
    }
    std::vector<std::string> warnings;
    const csg::HeightMap map = csg::readHeightMap(dat, warnings);
    EXPECT_TRUE(warnings.empty());
    ASSERT_EQ(map.rows.size(), 3u);
    EXPECT_EQ(map.columns, 4u);
    const mesh::TriMesh m = csg::surfaceMesh(map, false);
    const mesh::MeshReport r = mesh::check(m);
    EXPECT_TRUE(r.isWatertight() && r.isOriented() && r.isVertexManifold()) << r.boundaryEdges << " open edges";
    EXPECT_EQ(r.negativeComponents, 0u);
    // 6 cells of 4 triangles each to their mean height, over a floor at min(0, lowest - 1) = -1.
    EXPECT_EQ(m.triangles.size(), 24u + 2 * 10 + 2 * 6);  // top, walls of the 10 rim edges, floor
    EXPECT_EQ(r.zeroAreaTriangles, 0u);
    const mesh::Bounds b = mesh::bounds(m);
    EXPECT_EQ(b.min, glm::vec3(0, 0, -1));
    EXPECT_EQ(b.max, glm::vec3(3, 2, 8));
    // A value that is not a number ends the map with a warning naming the file and the line.
    {
        std::ofstream f(dat);
        f << "1 2\n3 x 4\n5 6\n";
    }
    warnings.clear();
    EXPECT_EQ(csg::readHeightMap(dat, warnings).rows.size(), 2u);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("map.dat:2: 'x' is not a number"), std::string::npos) << warnings[0];
}

TEST(OpenScadImport, MeshFilesAsSolidsMissingOnesSkippedDrawingsRefused) {
    const std::string dir = testing::TempDir();
    mesh::TriMesh cube;  // a unit cube, written as STL as OpenSCAD models import it
    for (int i = 0; i < 8; ++i) cube.positions.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
    cube.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                      {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    mesh::writeMesh(dir + "/cube.stl", cube);
    // parseScene reads paths from the working directory (readScene: from the scene's own).
    const auto s = csg::parseScene("import(\"" + dir + "/cube.stl\", scale = 2);\nimport(\"missing.stl\");", "s.isf");
    EXPECT_NEAR(s.root->value(glm::vec3(1.f)), -1.f, 1e-5f);  // scaled by 2: centre 1, 1 from each face
    EXPECT_NEAR(s.root->bounds().max.x, 2.f, 1e-5f);
    ASSERT_EQ(s.warnings.size(), 1u) << warnings(s);
    EXPECT_EQ(s.warnings[0].loc.line, 2);
    EXPECT_NE(s.warnings[0].message.find("cannot open 'missing.stl'"), std::string::npos);
    // An imported mesh has a geometry: hull() and minkowski() take it.
    const auto h =
        csg::parseScene("hull() { import(\"" + dir + "/cube.stl\"); translate([3, 0, 0]) cube(1); }", "h.isf");
    EXPECT_LT(h.root->value(glm::vec3(2.f, 0.5f, 0.5f)), 0.f);
    {
        std::ofstream f(dir + "/drawing.dxf");
        f << "0\nEOF\n";
    }
    try {
        csg::parseScene("import(\"" + dir + "/drawing.dxf\");", "d.isf");
        FAIL() << "accepted a DXF";
    } catch (const std::exception& e) {
        EXPECT_NE(std::string(e.what()).find("not supported"), std::string::npos) << e.what();
    }
}
