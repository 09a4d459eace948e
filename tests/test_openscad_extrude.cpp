// OpenSCAD's twisted and scaled linear_extrude: the same polyhedron OpenSCAD 2021.01 builds, its 2D
// booleans by Clipper, caps of profiles with holes, and the extrusions OpenSCAD drops from booleans.
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "csg/profile.h"
#include "csg/scene.h"
#include "csg/sectors.h"
#include "csg/shapes.h"
#include "mesh/check.h"
#include "mesh/triangulate.h"
#include "test_util.h"
#include "volume/marching_cubes.h"
#include "volume/sample.h"
#include "volume/vdb_io.h"

using namespace isoforge;

namespace {
struct Init {
    Init() { volume::initializeOpenVdb(); }
} init;

csg::Profile unionOf(const csg::Profile& a, const csg::Profile& b) {
    return combineProfiles({&a, &b}, csg::ProfileOp::Union);
}
csg::Profile differenceOf(const csg::Profile& a, const csg::Profile& b) {
    return combineProfiles({&a, &b}, csg::ProfileOp::Difference);
}
csg::Profile moved(const csg::Profile& p, double x, double y) {
    glm::dmat4 m(1.0);
    m[3] = glm::dvec4(x, y, 0, 1);
    return transformProfile(p, m);
}
csg::ExtrudeParams extrusion(double twist, int slices, glm::dvec2 scale) {
    csg::ExtrudeParams e;
    e.height = 5;
    e.twistDeg = twist;
    e.slices = slices;
    e.scale = scale;
    return e;
}
}  // namespace

TEST(OpenScadExtrude, TheSamePolyhedronAsOpenScad) {
    // Each case was exported by OpenSCAD 2021.01 (`openscad -o X.stl`, linear_extrude(height = 5, ...)),
    // its STL's volume summed in double: the meshes are the same, so the volumes agree to float rounding.
    struct Case {
        const char* what;
        csg::Profile profile;
        csg::ExtrudeParams e;
        double openscad;
    };
    const csg::Profile ring = differenceOf(csg::squareProfile({2, 2}, true), csg::squareProfile({1, 1}, true));
    const csg::Profile frame =
        differenceOf(moved(csg::squareProfile({10, 10}, false), -1, -1), csg::squareProfile({8, 8}, false));
    const csg::Profile pair =
        unionOf(moved(csg::squareProfile({1, 1}, false), 0.5, 0), moved(csg::squareProfile({1, 1}, false), -0.5, 0));
    const std::vector<Case> cases = {
        {"square(10), twist 45, 3 slices", csg::squareProfile({10, 10}, false), extrusion(45, 3, {1, 1}),
         537.4572745631979},
        // No slices given: OpenSCAD's count from $fa = 12, $fs = 2 (get_helix_slices).
        {"triangle, twist -45", csg::polygonProfile({{-5, -2.5}, {5, -2.5}, {0, 2.5}}, {}), extrusion(-45, 0, {1, 1}),
         140.45691205964687},
        {"square ring, twist 180, scale [0, 1]", ring, extrusion(180, 20, {0, 1}), 7.858346590727198},
        {"two touching squares, twist 180, scale [0, 0]", pair, extrusion(180, 20, {0, 0}), 3.5347572614587803},
        // get_diagonal_slices for the uneven scale, its walls split along the shorter diagonal.
        {"circle($fn = 7), twist 90, scale [2, 0.5]", csg::circleProfile(3, 7), extrusion(90, 0, {2, 0.5}),
         138.25614383424582},
        {"square frame, twist 30, 2 slices", frame, extrusion(30, 2, {1, 1}), 193.48432960546245},
    };
    for (const Case& c : cases) {
        const mesh::TriMesh m = csg::extrudeProfile(c.profile, c.e);
        const mesh::MeshReport r = mesh::check(m);
        EXPECT_NEAR(r.volume, c.openscad, 2e-6 * c.openscad) << c.what;
        EXPECT_TRUE(r.isWatertight() && r.isOriented()) << c.what << "\n" << r.toString();
    }
}

TEST(OpenScadExtrude, ClipperOutlinesAndOpenScadsTrigonometry) {
    // A hole: one positive outline counter-clockwise, one negative clockwise.
    const csg::Profile ring = differenceOf(csg::squareProfile({2, 2}, true), csg::squareProfile({1, 1}, true));
    ASSERT_EQ(ring.outlines.size(), 2u);
    EXPECT_NE(ring.outlines[0].positive, ring.outlines[1].positive);
    // A clockwise polygon is turned counter-clockwise; a mirror keeps outlines positive.
    const csg::Profile cw = csg::polygonProfile({{0, 0}, {0, 1}, {1, 0}}, {});
    ASSERT_EQ(cw.outlines.size(), 1u);
    EXPECT_TRUE(cw.outlines[0].positive);
    glm::dmat4 mirror(1.0);
    mirror[0][0] = -1;
    const csg::Profile m = transformProfile(csg::squareProfile({1, 1}, false), mirror);
    ASSERT_EQ(m.outlines.size(), 1u);
    EXPECT_TRUE(m.outlines[0].positive);
    // Exact at OpenSCAD's special angles, so that a half turn lands points exactly.
    EXPECT_EQ(csg::sinDegrees(180), 0.0);
    EXPECT_EQ(csg::cosDegrees(-90), 0.0);
    EXPECT_EQ(csg::sinDegrees(30), 0.5);
    EXPECT_EQ(csg::cosDegrees(360 + 60), 0.5);
    EXPECT_NEAR(csg::sinDegrees(10), std::sin(10 * M_PI / 180), 1e-15);
}

TEST(OpenScadExtrude, CapsOfRegionsWithHoles) {
    // A 10 x 10 square with two square holes and a triangular one, joined by bridges and ear-clipped.
    std::vector<glm::vec3> p = {{0, 0, 0}, {10, 0, 0}, {10, 10, 0}, {0, 10, 0}};
    auto hole = [&](std::vector<glm::vec2> q) {
        std::vector<int> loop;
        for (const glm::vec2& v : q) {
            loop.push_back(int(p.size()));
            p.emplace_back(v.x, v.y, 0.f);
        }
        return loop;
    };
    const std::vector<std::vector<int>> holes = {
        hole({{1, 1}, {1, 3}, {3, 3}, {3, 1}}), hole({{6, 6}, {6, 8}, {8, 8}, {8, 6}}), hole({{2, 6}, {2, 8}, {4, 6}})};
    const std::vector<int> outer = {0, 1, 2, 3};
    const auto tris = mesh::triangulateRegionXY(p, outer, holes);
    EXPECT_EQ(tris.size(), 4 + 4 + 4 + 3 - 2 + 2 * 3);  // n - 2 + 2 per hole
    double area = 0;
    for (const auto& t : tris) {
        const glm::vec3 a = p[t.x], b = p[t.y], c = p[t.z];
        const double s = 0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
        EXPECT_GT(s, 0) << "every triangle counter-clockwise, as the outer loop";
        area += s;
    }
    EXPECT_NEAR(area, 100 - 4 - 4 - 2, 1e-9);
}

TEST(OpenScadExtrude, ExportsGetOpenScadsSolidAndItsDrops) {
    auto meshOf = [](const std::string& text, std::string* warnings = nullptr) {
        const auto s = csg::parseScene(text, "x.csg");
        if (warnings)
            for (const auto& w : s.warnings) *warnings += w.message + "\n";
        volume::SampleOptions o;
        o.voxelSize = 0.02f;
        return test::expectClosedSurface(volume::extractIsosurface(*volume::sample(s.root, o)), text);
    };
    // OpenSCAD's export of a twisted square: its sliced walls (a continuous twist holds 1.5% more).
    const std::string twisted =
        "linear_extrude(height = 5, center = false, convexity = 1, twist = 45, slices = 3, scale = [1, 1]) {\n"
        "  square(size = [1, 1], center = false);\n}\n";
    EXPECT_NEAR(meshOf(twisted).volume, 537.4572745631979 / 100, 0.003 * 5.374572745631979);
    // Two squares pinched to one point by scale 0: kept alone, dropped with a warning beside a cube
    // (OpenSCAD's CGAL conversion refuses the pinched vertex: "The given mesh is not closed!").
    const std::string pinched =
        "linear_extrude(height = 5, center = false, convexity = 1, twist = 180, slices = 20, scale = [0, 0]) {\n"
        "  translate([1, 0]) square(size = [1, 1], center = true);\n"
        "  translate([-1, 0]) square(size = [1, 1], center = true);\n}\n";
    EXPECT_GT(meshOf(pinched).volume, 0.5);
    std::string warnings;
    const double withCube = meshOf("translate([20, 0, 0]) cube(size = [1, 1, 1]);\n" + pinched, &warnings).volume;
    EXPECT_NEAR(withCube, 1.0, 0.01);
    EXPECT_NE(warnings.find("The given mesh is not closed!"), std::string::npos) << warnings;
}

TEST(OpenScadExtrude, MeshesSignedByWindingNumberMakeNoBlobsAtSamplesOnEdges) {
    // OpenSCAD's export of extrude.scad's tapered screw as a mesh signed by the generalized winding
    // number (as polyhedra and mesh() files are): its bottom edges lie on grid samples (z = 0), where
    // rounding gave the solid angle of a triangle seen from its own edge as up to +-2 pi, and marching
    // cubes made 4 blobs around such samples at this voxel size (15 at 0.1).
    const mesh::TriMesh m = csg::extrudeProfile(csg::squareProfile({10, 10}, true), [] {
        csg::ExtrudeParams e;
        e.height = 20;
        e.twistDeg = 90;
        e.scale = {0.5, 0.5};
        e.slices = 200;
        return e;
    }());
    std::vector<glm::uvec3> tris(m.triangles.begin(), m.triangles.end());
    const auto f = csg::makeTriangleMeshField(m.positions, tris, "screw", nullptr, false);
    volume::SampleOptions o;
    o.voxelSize = 0.2f;
    const auto r = test::expectClosedSurface(volume::extractIsosurface(*volume::sample(f, o)), "screw");
    EXPECT_EQ(r.components, 1u);
    EXPECT_NEAR(r.volume, 1169.709, 0.005 * 1169.709);  // OpenSCAD's STL
}

TEST(OpenScadExtrude, HostileSliceCountsAreBounded) {
    // A twist of 1e12 degrees asks OpenSCAD's formula for more slices than an int holds; the count is
    // clamped, and past 4 million wall triangles the export keeps the continuous twist, with a warning.
    csg::ExtrudeParams e = extrusion(1e12, 0, {1, 1});
    EXPECT_EQ(csg::openscadSlices(csg::squareProfile({1, 1}, false), e), csg::kMaxSlices);
    e.fa = std::nan("");
    EXPECT_GE(csg::openscadSlices(csg::squareProfile({1, 1}, false), e), 1);
    EXPECT_THROW(csg::extrudeProfile(csg::squareProfile({1, 1}, false), extrusion(1e12, 0, {1, 1})), std::length_error);
    const auto s = csg::parseScene(
        "linear_extrude(height = 5, center = false, convexity = 1, twist = 1e12, scale = [1, 1], $fn = 0, $fa = 12, "
        "$fs = 2) {\n  square(size = [1, 1], center = false);\n}\n",
        "x.csg");
    ASSERT_EQ(s.warnings.size(), 1u);
    EXPECT_NE(s.warnings[0].message.find("the twist is continuous here instead"), std::string::npos);
}

TEST(OpenScadExtrude, PathIndicesPastIntsRangeAreOutOfRangeLikeAnyOther) {
    // fuzz_scene: a path index of 3e58 was converted to int (undefined behaviour). It is out of range
    // like index 99: the polygon is dropped with a warning naming it, and the rest of the scene is kept.
    auto check = [](const std::string& index) {
        const auto s = csg::parseScene(
            "cube(1);\nlinear_extrude(height = 1) polygon(points = [[0, 0], [4, 0], "
            "[4, 4], [0, 4]], paths = [[0, 1, 2, 3, " +
                index + "]]);\n",
            "p.csg");
        EXPECT_LT(s.root->value(glm::vec3(0.5f)), 0.f) << index;
        EXPECT_GT(s.root->value(glm::vec3(2.f, 2.f, 0.5f)), 0.f) << index;
        return s.warnings.size() == 1 ? s.warnings[0].message : std::string("(no single warning)");
    };
    for (const auto& [index, shown] :
         {std::pair{"99", "99"}, {"3e58", "3e+58"}, {"-3e58", "-3e+58"}, {"2147483648", "2147483648"}, {"4.5", "4.5"}})
        EXPECT_EQ(check(index), std::string("polygon: a path names point ") + shown +
                                    ", but there are 4: it is empty and ignored, as OpenSCAD does");
}

TEST(OpenScadExtrude, CoordinatesPastClippersRangeAreRefusedByItsRangeCheck) {
    // fuzz_scene: 1e19 scaled by 2^16 was converted to a 64-bit integer (undefined behaviour; on x86 the
    // most negative integer, which Clipper's range check lets through). Clipper refuses coordinates past
    // 2^62 / 2^16, and OpenSCAD gets nothing from it: the same for 1e14, 1e19, 1e300 and NaN. (The
    // conversion itself is caught by UBSan when scripts/fuzz.sh replays tests/data/fuzz/scene/.)
    for (double x : {1e14, 1e19, -1e19, 1e300, std::nan("")})
        EXPECT_TRUE(csg::polygonProfile({{x, 0}, {1, 0}, {1, 2}}, {}).outlines.empty()) << x;
    EXPECT_EQ(csg::polygonProfile({{1e13, 0}, {1, 0}, {1, 2}}, {}).outlines.size(), 1u);  // within the range
}

TEST(OpenScadExtrude, OffsetOfOutlinesAsOpenScadsClipperOffset) {
    auto at = [](const char* scene, float x, float y) {
        return csg::parseScene(std::string("linear_extrude(1) ") + scene, "o.isf").root->value(glm::vec3(x, y, 0.5f));
    };
    // r: round corners (OpenSCAD's $fa/$fs facets), delta: mitred, delta with chamfer: cut.
    EXPECT_LT(at("offset(r = 1, $fn = 64) square(10);", -0.6f, -0.6f), 0.f);
    EXPECT_GT(at("offset(r = 1, $fn = 64) square(10);", -0.9f, -0.9f), 0.f);
    EXPECT_LT(at("offset(delta = 1) square(10);", -0.9f, -0.9f), 0.f);
    EXPECT_GT(at("offset(delta = 1, chamfer = true) square(10);", -0.9f, -0.9f), 0.f);
    EXPECT_LT(at("offset(delta = 1, chamfer = true) square(10);", -0.9f, 5.f), 0.f);
    // A negative offset shrinks, and grows holes: a 4-wide hole in a 10-square offset by -2 leaves nothing.
    EXPECT_GT(at("offset(r = -1) square(10);", 0.5f, 5.f), 0.f);
    EXPECT_LT(at("offset(r = -1) square(10);", 1.5f, 5.f), 0.f);
    const auto gone = csg::parseScene(
        "linear_extrude(1) offset(r = -2) difference() { square(10); translate([3, 3]) square(4); }", "g.isf");
    EXPECT_TRUE(gone.root->bounds().isEmpty());
    // Of a 3D object, our extension: the field's offset.
    EXPECT_NEAR(csg::parseScene("offset(r = 0.5) sphere(1);", "s.isf").root->value(glm::vec3(0.f)), -1.5f, 1e-5f);
}

TEST(OpenScad, SectorsFindTheFacetWithoutTrigonometry) {
    // The polynomial atan2 behind the faceted fields ($fn spheres, cylinders, circles, revolutions).
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1, 1);
    double worst = 0;
    for (int i = 0; i < 200000; ++i) {
        const double x = u(rng), y = u(rng);
        worst = std::max(worst, std::abs(csg::Sectors::atan2Approx(y, x) - std::atan2(y, x)));
    }
    for (double a = -M_PI; a <= M_PI; a += M_PI / 8)  // axes and diagonals exactly
        worst = std::max(worst, std::abs(csg::Sectors::atan2Approx(std::sin(a), std::cos(a)) -
                                         std::atan2(std::sin(a), std::cos(a))));
    EXPECT_LT(worst, kFastAtan2Error);
    EXPECT_LT(kFastAtan2Error, 0.5 * csg::Sectors::kGuessError);
    EXPECT_EQ(csg::Sectors::atan2Approx(0, 0), 0.0);

    // support() is the dot product with the middle of the sector the point's angle is in (what
    // atan2, floor, cos and sin compute), for full turns and open fans, few sectors and very many,
    // points anywhere and points on the sectors' boundaries.
    struct Case {
        int n;
        double step, start;
        bool closed;
    };
    const std::vector<Case> cases{{3, 2 * M_PI / 3, 0, true},
                                  {4, M_PI / 2, M_PI / 4, true},
                                  {7, 2 * M_PI / 7, -1.0, true},
                                  {96, 2 * M_PI / 96, 0, true},
                                  {20, 2 * M_PI / 20, M_PI / 2 - M_PI / 20, true},
                                  {200000, 2 * M_PI / 200000, 0, true},
                                  {2, 50 * M_PI / 180, 0, false},
                                  {5, 0.5, -2.5, false},
                                  {30, 0.2, -6.0, false}};
    for (const Case& c : cases) {
        const csg::Sectors sectors(c.n, c.step, c.start, c.closed);
        auto exact = [&](double x, double y) {
            double phi = std::atan2(y, x) - c.start;
            phi -= 2 * M_PI * std::floor(phi / (2 * M_PI));
            const double mid = c.start + (std::floor(phi / c.step) + 0.5) * c.step;
            return x * std::cos(mid) + y * std::sin(mid);
        };
        auto inFan = [&](double x, double y) {
            double phi = std::atan2(y, x) - c.start;
            phi -= 2 * M_PI * std::floor(phi / (2 * M_PI));
            return c.closed || phi < c.n * c.step;
        };
        int checked = 0;
        auto check = [&](double x, double y) {
            if (!inFan(x, y)) return;
            ++checked;
            ASSERT_NEAR(sectors.support(x, y), exact(x, y), 1e-9 * (std::abs(x) + std::abs(y)))
                << c.n << " sectors at (" << x << ", " << y << ")";
        };
        for (int i = 0; i < 20000; ++i) check(10 * u(rng), 10 * u(rng));
        for (int k = 0; k <= std::min(c.n, 400); ++k) {  // on boundaries, and a hair either side
            const double a = c.start + k * c.step;
            for (double e : {-1e-9, 0.0, 1e-9}) check(3 * std::cos(a + e), 3 * std::sin(a + e));
        }
        EXPECT_GT(checked, 1000) << c.n;
    }
}
