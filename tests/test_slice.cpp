#include <gtest/gtest.h>

#include "implicit/primitives.h"
#include "implicit/tape.h"
#include "render/slice.h"
#include "test_util.h"

using namespace isoforge;

TEST(Slice, SignImageOfADiscMatchesTheAnalyticArea) {
    render::SliceOptions o;
    o.size = 512;
    o.sign = true;
    render::SliceStats st;
    const auto img = render::sliceField(implicit::makeSphere(0.5f), o, &st);
    std::size_t black = 0;
    for (int y = 0; y < o.size; ++y)
        for (int x = 0; x < o.size; ++x) black += img.at(x, y)[0] == 0.f;
    const double area = double(black) / (512.0 * 512.0) * 4.0;
    EXPECT_NEAR(area, M_PI * 0.25, 0.005);
    EXPECT_GT(st.tilesFilled, 0u);                   // bounds filled whole tiles
    EXPECT_LT(st.pointsEvaluated, 512u * 512u / 2);  // far fewer points than pixels
}

TEST(Slice, RowZeroIsTheTopAndAxesFollowThePlane) {
    // The half-space y > 0.5 is outside: on a z-slice, the top rows are white, the bottom black.
    auto f = implicit::makeTapeField(implicit::parseExpression("y - 0.5"), implicit::Box3::everything(), "y");
    render::SliceOptions o;
    o.size = 64;
    o.sign = true;
    auto img = render::sliceField(f, o);
    EXPECT_EQ(img.at(10, 0)[0], 1.f);
    EXPECT_EQ(img.at(10, 63)[0], 0.f);
    // On an x-slice, the vertical axis is z: y is horizontal, so columns differ, rows not.
    o.axis = 0;
    img = render::sliceField(f, o);
    EXPECT_EQ(img.at(63, 5)[0], 1.f);
    EXPECT_EQ(img.at(0, 5)[0], 0.f);
}

TEST(Slice, PrunedTapeGivesTheSameImageAsPointEvaluation) {
    std::string e = "sqrt(x^2 + y^2) - 0.05";
    for (int i = 1; i < 60; ++i)
        e = "min(" + e + ", sqrt((x - " + std::to_string(-0.9 + 0.03 * i) + ")^2 + (y - " +
            std::to_string(0.5 * std::sin(i)) + ")^2) - 0.04)";
    auto f = implicit::makeTapeField(implicit::parseExpression(e), implicit::Box3::everything(), "dots");
    render::SliceOptions o;
    o.size = 200;
    for (bool sign : {true, false}) {
        o.sign = sign;
        const auto img = render::sliceField(f, o);
        int mismatches = 0;
        for (int y = 0; y < o.size; ++y)
            for (int x = 0; x < o.size; ++x) {
                const float u = -1.f + (x + 0.5f) * 2.f / o.size, v = 1.f - (y + 0.5f) * 2.f / o.size;
                const float val = f->value(glm::vec3(u, v, 0.f));
                if (sign) mismatches += img.at(x, y)[0] != (val < 0.f ? 0.f : 1.f);
            }
        EXPECT_EQ(mismatches, 0);
    }
}
