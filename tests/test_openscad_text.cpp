// OpenSCAD's text(): fontconfig, HarfBuzz and FreeType as OpenSCAD 2021.01 calls them. The corpus
// test compares whole models with OpenSCAD's own meshes (LetterBlock, tessellation-text-test); these
// check the layout rules that do not depend on which font fontconfig finds.
#include <string>

#include <gtest/gtest.h>

#include "csg/scene.h"
#include "csg/text.h"

using namespace isoforge;

namespace {
struct Extent {
    glm::dvec2 lo{1e300}, hi{-1e300};
};
Extent extentOf(const csg::Profile& p) {
    Extent e;
    for (const auto& o : p.outlines)
        for (const glm::dvec2& q : o.points) e.lo = glm::min(e.lo, q), e.hi = glm::max(e.hi, q);
    return e;
}
}  // namespace

TEST(OpenScadText, LayoutAlignmentHolesAndSize) {
    csg::TextParams t;
    t.text = "Ob";
    std::string font;
    const csg::Profile left = csg::textProfile(t, &font);
    EXPECT_FALSE(font.empty());
    // O and b each have a hole: outlines of both signs.
    int holes = 0;
    for (const auto& o : left.outlines) holes += !o.positive;
    EXPECT_EQ(holes, 2);
    const Extent l = extentOf(left);
    EXPECT_NEAR(l.lo.y, -0.2, 0.5);  // on the baseline (an O dips a little below it)
    EXPECT_GT(l.hi.y, 6.0);          // size 10: capitals about 7 units tall
    EXPECT_LT(l.hi.y, 14.0);         // the b's ascender is taller
    // Centred: the advance width is split about x = 0; right: it ends at 0.
    t.halign = "center";
    const Extent c = extentOf(csg::textProfile(t));
    EXPECT_NEAR(c.lo.x - l.lo.x, c.hi.x - l.hi.x, 1e-4);  // a shift only (to Clipper's 2^-16 grid)
    EXPECT_LT(c.lo.x, 0.0);
    EXPECT_GT(c.hi.x, 0.0);
    t.halign = "right";
    t.valign = "top";
    const Extent r = extentOf(csg::textProfile(t));
    EXPECT_LE(r.hi.x, 1e-9 + 1.0);  // the last advance ends at 0 (the glyph may stop short of it)
    EXPECT_NEAR(r.hi.y, 0.0, 0.5);  // valign top: the tallest glyph's grid-fitted box at 0
    // size scales everything.
    t = csg::TextParams{};
    t.text = "Ob";
    t.size = 20;
    const Extent big = extentOf(csg::textProfile(t));
    EXPECT_NEAR(big.hi.x, 2 * l.hi.x, 1e-6 * big.hi.x);
}

TEST(OpenScadText, ExtrudedTextIsASolidAndEmptyTextIsSkipped) {
    const auto s = csg::parseScene("linear_extrude(2) text(\"T\", size = 10);", "t.isf");
    const auto b = s.root->bounds();
    const float mid = 0.5f * (b.min.x + b.max.x);
    EXPECT_LT(s.root->value(glm::vec3(mid, 0.4f * b.max.y, 1.f)), 0.f);             // the stem of the T
    EXPECT_GT(s.root->value(glm::vec3(b.min.x + 0.3f, 0.4f * b.max.y, 1.f)), 0.f);  // beside it
    EXPECT_LT(s.root->value(glm::vec3(b.min.x + 0.3f, b.max.y - 0.3f, 1.f)), 0.f);  // the bar
    const auto empty = csg::parseScene("linear_extrude(2) text(\"\");\ncube(1);", "e.isf");
    ASSERT_EQ(empty.warnings.size(), 1u);
    EXPECT_NE(empty.warnings[0].message.find("text()"), std::string::npos);
}
