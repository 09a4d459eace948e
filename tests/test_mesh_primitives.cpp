// Polygonal primitives: closed, manifold, outward at several resolutions, with the right genus and a
// volume that converges to the analytic one.
#include <cmath>

#include <gtest/gtest.h>

#include "mesh/primitives.h"
#include "test_util.h"

using namespace isoforge;

TEST(Primitives, ClosedOutwardAndConvergingAtSeveralResolutions) {
    struct Case {
        const char* name;
        double volume;  // of the smooth shape
        long long genus;
        std::vector<int> resolutions;
    };
    const double pi = M_PI;
    for (const Case& c :
         {Case{"cube", 1.0, 0, {1, 2, 7}}, Case{"cylinder", pi * 0.25, 0, {3, 8, 64, 256}},
          Case{"cone", pi * 0.25 / 3, 0, {3, 8, 64, 256}}, Case{"sphere", 4.0 / 3 * pi * 0.125, 0, {3, 8, 64, 256}},
          Case{"icosphere", 4.0 / 3 * pi * 0.125, 0, {0, 1, 3, 5}},
          Case{"torus", 2 * pi * pi * 0.5 * 0.04, 1, {3, 8, 64, 256}}}) {
        double previousError = 1e30;
        for (int res : c.resolutions) {
            const auto m = mesh::makePrimitive(c.name, res);
            const std::string what = std::string(c.name) + " at " + std::to_string(res);
            const auto r = test::expectClosedSurface(m, what);
            EXPECT_EQ(r.components, 1u) << what;
            EXPECT_EQ(r.genus().value_or(-1), c.genus) << what;
            const double error = std::abs(r.volume - c.volume) / c.volume;
            EXPECT_LE(error, previousError + 1e-12) << what << ": volume error grows with the resolution";
            previousError = error;
        }
        EXPECT_LT(previousError, c.genus == 0 && std::string(c.name) == "cube" ? 1e-6 : 2e-3) << c.name;
    }
    EXPECT_THROW(mesh::makePrimitive("teapot", 8), std::invalid_argument);
    EXPECT_THROW(mesh::makePrimitive("cone", 2), std::invalid_argument);
    EXPECT_THROW(mesh::makePrimitive("cube", 1000000), std::invalid_argument);
}
