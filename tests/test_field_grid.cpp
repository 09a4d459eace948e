// The cell grid the field marcher walks (render/field_grid.h): its cells' classes against the field's
// values, and its walk against the cells that points along a ray fall in, jumps over empty space
// included; and the box automatic framing fits (volume/surface_box.h).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include <glm/geometric.hpp>

#include "csg/scene.h"
#include "render/field_grid.h"
#include "volume/surface_box.h"

using namespace isoforge;

namespace {

/// Spheres, a thin box and a blobby, with colours (one translucent): cells of every class.
csg::Scene testScene() {
    return csg::parseScene(R"(
        color("white") box(size = [10, 8, 0.4], center = true);
        translate([-2, 1, 1.2]) color("steelblue") sphere(1.1);
        translate([2, -1, 0.3]) color("gold") blobby(threshold = 0.5) {
            ball(center = [0, 0, 0.8], r = 1.6);
            ball(center = [0.6, 0.2, 1.4], r = 1.3);
        }
        translate([0, -2.5, 1.5]) color([0.5, 0.8, 0.95, 0.5]) sphere(0.8);
    )",
                           "grid.isf");
}

}  // namespace

TEST(FieldGrid, CellsAgreeWithTheFieldAndWalksVisitTheCellsPointsFallIn) {
    const csg::Scene s = testScene();
    const implicit::Box3 region = s.root->bounds().expanded(0.05f);
    const render::detail::FieldGrid grid(s.root, region, 48);
    ASSERT_GT(grid.surfaceCells(), 100u);
    ASSERT_LT(grid.surfaceCells(), grid.cells() / 4);
    const glm::vec3 size = region.size();
    const float h = std::max({size.x, size.y, size.z}) / 48.f;
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    std::size_t seeThrough = 0, steps = 0, jumps = 0, wrong = 0;
    for (int ray = 0; ray < 400; ++ray) {
        // From a point on the region's boundary box (and sometimes inside it) in a random direction.
        const glm::vec3 o = region.min + glm::vec3(u(rng), u(rng), u(rng)) * size;
        glm::vec3 d(u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f);
        if (ray % 7 == 0) d = glm::vec3(0.f, 0.f, -1.f);  // along an axis: two directions are zero
        d = glm::normalize(d);
        float tEnd = 1e9f;
        for (int k = 0; k < 3; ++k)
            if (d[k] != 0.f) tEnd = std::min(tEnd, ((d[k] > 0 ? region.max[k] : region.min[k]) - o[k]) / d[k]);
        float last = 0.f;
        grid.walk(o, d, 0.f, tEnd, [&](std::int32_t code, float t0, float t1) -> bool {
            EXPECT_FLOAT_EQ(t0, last) << "the cells a walk visits follow each other";
            EXPECT_GE(t1, t0);
            last = t1;
            ++steps;
            // Points well inside the span: their sign is the cell's class, or the cell's field is
            // the whole field's there.
            for (int k = 1; k < 8; ++k) {
                const float t = t0 + (t1 - t0) * float(k) / 8.f;
                const glm::vec3 p = o + t * d;
                const float v = s.root->value(p);
                if (code == render::detail::FieldGrid::kOutside)
                    wrong += !(v > 0.f);
                else if (code == render::detail::FieldGrid::kInside)
                    wrong += !(v < 0.f);
                else
                    wrong += !(std::abs(grid.field(code).value(p) - v) <= 1e-5f * (1.f + std::abs(v)));
            }
            if (code >= 0 && grid.seeThrough(code)) ++seeThrough;
            if (t1 - t0 > 2.f * h) ++jumps;  // longer than any one cell: a jump over empty cells
            return false;
        });
        EXPECT_NEAR(last, tEnd, 1e-4f * (1.f + tEnd)) << "a walk reaches the end of its span";
    }
    EXPECT_EQ(wrong, 0u) << "points whose value disagrees with their cell";
    EXPECT_GT(seeThrough, 0u) << "the glass sphere's cells let shadow rays through";
    EXPECT_GT(jumps, steps / 50) << "empty space is crossed in steps of many cells";
}

TEST(FieldGrid, TranslucencyFollowsTheInnermostColour) {
    const auto glass = [](const char* scene) { return csg::parseScene(scene, "t.isf").root->translucent(false); };
    EXPECT_TRUE(glass("color([1, 1, 1, 0.5]) sphere(1);"));
    EXPECT_FALSE(glass("sphere(1);"));  // no colour: opaque
    EXPECT_FALSE(glass("color([1, 1, 1, 0.5]) union() { sphere(1); color(\"red\") cube(1); }"));
    EXPECT_TRUE(glass("color(\"red\") union() { color([1, 1, 1, 0.5]) sphere(1); color([0, 0, 1, 0.2]) cube(1); }"));
    EXPECT_FALSE(glass("union() { color([1, 1, 1, 0.5]) sphere(1); cube(1); }"));
    EXPECT_TRUE(glass("translate([1, 0, 0]) color([1, 1, 1, 0.5]) difference() { sphere(1); cube(1); }"));
}

TEST(SurfaceBox, FramesWhatTheMeshPathsVerticesSpan) {
    // Fields whose own bounds are loose (a blobby's are its balls' supports; a difference's and an
    // intersection's their first child's) and one whose bounds are exact: the box of a coarse mesh's
    // vertices (what the march path frames) against the vertices of the fine mesh the mesh path
    // renders (512 voxels there; 256 here): within a coarse voxel's chord, and well inside the
    // field's own bounds where those are loose.
    const char* scenes[] = {
        "blobby(threshold = 0.5) { ball(center = [0, 0, 0], r = 1.6); ball(center = [0.6, 0.2, 0.9], r = 1.3); }",
        "difference() { intersection() { cube(3, center = true); sphere(2); } cylinder(h = 4, r = 0.75, center = "
        "true); }",
        "translate([1, 2, 3]) cube([1, 2, 3]);",
        "intersection() { sphere(1); translate([0, 0, 0.8]) cube(2, center = true); }",
    };
    for (const char* text : scenes) {
        const csg::Scene s = csg::parseScene(text, "box.isf");
        const implicit::Box3 everything = implicit::Box3::everything();
        const implicit::Box3 coarse = volume::surfaceBox(s.root, everything, 128);
        const implicit::Box3 fine = volume::surfaceBox(s.root, everything, 256);
        ASSERT_FALSE(coarse.isEmpty()) << text;
        const implicit::Box3 loose = s.root->bounds();
        const float voxel = std::max({loose.size().x, loose.size().y, loose.size().z}) / 128.f;
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(coarse.min[k], fine.min[k], 0.25f * voxel) << text << " axis " << k;
            EXPECT_NEAR(coarse.max[k], fine.max[k], 0.25f * voxel) << text << " axis " << k;
        }
        if (std::string(text).find("blobby") != std::string::npos) {
            EXPECT_LT(glm::length(coarse.size()), 0.8f * glm::length(loose.size())) << "a blobby's supports are loose";
        }
    }
    const csg::Scene none = csg::parseScene("difference() { cube(1); cube(3, center = true); }", "none.isf");
    EXPECT_TRUE(volume::surfaceBox(none.root, implicit::Box3::everything(), 64).isEmpty());
}
