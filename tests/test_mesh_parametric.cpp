// Parametric curves and surfaces: de Casteljau against the Bernstein form, de Boor against de
// Casteljau, exact NURBS conics, watertight tessellations of closed patch sets at several
// resolutions, Newell's teapot (patch corners, orientation), and the .bpt reader's errors.
#include <cmath>
#include <fstream>
#include <limits>
#include <string>

#include <glm/geometric.hpp>

#include <gtest/gtest.h>

#include "core/error.h"
#include "mesh/check.h"
#include "mesh/parametric.h"
#include "test_util.h"

using namespace isoforge;

namespace {
double bernstein(int n, int i, double t) {
    double c = 1;
    for (int k = 1; k <= i; ++k) c = c * double(n - i + k) / double(k);
    return c * std::pow(t, i) * std::pow(1 - t, n - i);
}
const std::vector<glm::dvec3> kControl = {{0, 0, 0}, {1, 2, 0}, {3, 3, 1}, {4, 0, 2}, {6, 1, -1}};
}  // namespace

TEST(Bezier, DeCasteljauMatchesTheBernsteinForm) {
    const int n = int(kControl.size()) - 1;
    for (double t = 0; t <= 1.0; t += 1.0 / 64) {
        glm::dvec3 expected(0.0);
        for (int i = 0; i <= n; ++i) expected += bernstein(n, i, t) * kControl[std::size_t(i)];
        EXPECT_LT(glm::length(mesh::bezierPoint(kControl, t) - expected), 1e-12) << t;
    }
    EXPECT_EQ(mesh::bezierPoint(kControl, 0.0), kControl.front());  // interpolates its ends
    EXPECT_EQ(mesh::bezierPoint(kControl, 1.0), kControl.back());
}

TEST(BSpline, ClampedWithoutInteriorKnotsIsTheBezierCurve) {
    mesh::NurbsCurve c;
    c.degree = 4;
    c.points = kControl;
    c.knots = {0, 0, 0, 0, 0, 1, 1, 1, 1, 1};
    c.validate();
    for (double t = 0; t <= 1.0; t += 1.0 / 50)
        EXPECT_LT(glm::length(c.evaluate(t) - mesh::bezierPoint(kControl, t)), 1e-12) << t;
}

TEST(BSpline, UniformCubicAtAKnotIsTheOneFourOneAverage) {
    mesh::NurbsCurve c;
    c.degree = 3;
    c.points = {{0, 0, 0}, {1, 3, 0}, {2, -1, 1}, {4, 2, 0}, {5, 5, 2}, {7, 0, 1}};
    c.knots = mesh::uniformKnots(int(c.points.size()), 3);
    c.validate();
    EXPECT_EQ(c.domainBegin(), 3.0);
    EXPECT_EQ(c.domainEnd(), 6.0);
    for (int i = 1; i + 1 < int(c.points.size()); ++i) {
        const double t = double(i + 2);  // the knot where P[i] has weight 4/6
        if (t < c.domainBegin() || t > c.domainEnd()) continue;
        const glm::dvec3 expected =
            (c.points[std::size_t(i - 1)] + 4.0 * c.points[std::size_t(i)] + c.points[std::size_t(i + 1)]) / 6.0;
        EXPECT_LT(glm::length(c.evaluate(t) - expected), 1e-12) << "knot " << t;
    }
    // Affine invariance (the basis sums to one): moving every control point moves the curve.
    mesh::NurbsCurve moved = c;
    for (glm::dvec3& p : moved.points) p += glm::dvec3(10, -3, 2);
    for (double t = 3; t <= 6; t += 0.1)
        EXPECT_LT(glm::length(moved.evaluate(t) - c.evaluate(t) - glm::dvec3(10, -3, 2)), 1e-12);
}

TEST(Nurbs, CircleIsExact) {
    const double r = 2.5;
    const mesh::NurbsCurve c = mesh::nurbsCircle(r);
    c.validate();
    double worst = 0;
    for (int i = 0; i <= 10000; ++i) {
        const glm::dvec3 p = c.evaluate(double(i) / 10000);
        worst = std::max(worst, std::abs(glm::length(p) - r));
        EXPECT_EQ(p.z, 0.0);
    }
    EXPECT_LT(worst / r, 1e-14);  // exact up to double rounding; well inside float precision
    EXPECT_LT(glm::length(c.evaluate(0.25) - glm::dvec3(0, r, 0)), 1e-15);
    EXPECT_LT(glm::length(c.evaluate(0.5) - glm::dvec3(-r, 0, 0)), 1e-15);
    // A non-rational B-spline on the same control points is not a circle.
    mesh::NurbsCurve polynomial = c;
    polynomial.weights.clear();
    EXPECT_GT(std::abs(glm::length(polynomial.evaluate(0.125)) - r), 0.1);
}

TEST(Nurbs, SphereAndTorusTessellateWatertightAndExact) {
    const double r = 1.5;
    double previousError = 1e300;
    for (int res : {4, 8, 16, 32, 64}) {
        const mesh::TriMesh m = mesh::tessellate(mesh::nurbsSphere(r), res);
        const auto rep = test::expectClosedSurface(m, "NURBS sphere at resolution " + std::to_string(res));
        EXPECT_EQ(rep.genus().value_or(-1), 0);
        for (const glm::vec3& p : m.positions) ASSERT_NEAR(glm::length(p), r, 1e-6 * r);
        const double error = std::abs(rep.volume - 4.0 / 3.0 * M_PI * r * r * r);
        EXPECT_LT(error, previousError) << "resolution " << res;
        previousError = error;
    }
    EXPECT_LT(previousError / (4.0 / 3.0 * M_PI * r * r * r), 3e-3);

    for (int res : {6, 16, 48}) {
        const mesh::TriMesh m = mesh::tessellate(mesh::nurbsTorus(2.0, 0.5), res);
        const auto rep = test::expectClosedSurface(m, "NURBS torus at resolution " + std::to_string(res));
        EXPECT_EQ(rep.genus().value_or(-1), 1);
        for (const glm::vec3& p : m.positions) {
            const double ring = std::hypot(p.x, p.y) - 2.0;
            ASSERT_NEAR(std::hypot(ring, double(p.z)), 0.5, 1e-6);
        }
    }
}

TEST(Nurbs, ValidationSaysWhatIsWrong) {
    mesh::NurbsCurve c = mesh::nurbsCircle(1);
    auto message = [](const mesh::NurbsCurve& x) {
        try {
            x.validate();
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    mesh::NurbsCurve bad = c;
    bad.knots.pop_back();
    EXPECT_NE(message(bad).find("need 12 knots, got 11"), std::string::npos) << message(bad);
    bad = c;
    std::swap(bad.knots[3], bad.knots[6]);
    EXPECT_NE(message(bad).find("must not decrease"), std::string::npos) << message(bad);
    bad = c;
    bad.weights[2] = 0;
    EXPECT_NE(message(bad).find("positive"), std::string::npos) << message(bad);
    bad = c;
    bad.degree = 9;
    EXPECT_NE(message(bad).find("at least 10 control points"), std::string::npos) << message(bad);
    bad = c;
    bad.points[4].y = std::nan("");  // found by fuzzing the scene parser: `0 % 0` in a point
    EXPECT_NE(message(bad).find("control point 5 of 9 is not finite"), std::string::npos) << message(bad);
    mesh::NurbsSurface sphere = mesh::nurbsSphere(1);
    sphere.points[3].z = std::numeric_limits<double>::infinity();
    EXPECT_THROW(sphere.validate(), std::invalid_argument);
    // Finite control points whose surface overflows: refused, not welded through a NaN cell index.
    mesh::NurbsSurface huge = mesh::nurbsSphere(1e308);
    EXPECT_THROW(mesh::tessellate(huge, 4), std::invalid_argument);
}

TEST(Teapot, TessellationHitsThePatchCornersAndIsConsistentlyOriented) {
    const auto patches = mesh::readBezierPatches(test::sourceDir() / "data/teapot.bpt");
    ASSERT_EQ(patches.size(), 32u);
    for (const auto& p : patches) {
        ASSERT_EQ(p.degreeU, 3);
        ASSERT_EQ(p.points.size(), 16u);
    }
    EXPECT_EQ(patches[0].at(0, 0), glm::dvec3(1.4, 0.0, 2.4));
    EXPECT_EQ(patches[31].at(3, 3), glm::dvec3(1.5, 0.0, 0.15));
    for (int res : {4, 16, 32}) {
        const mesh::TriMesh m = mesh::tessellate(patches, res);
        // Bézier patches interpolate their corner control points: each is a vertex of the mesh.
        for (std::size_t k = 0; k < patches.size(); ++k)
            for (const auto& [i, j] : {std::pair{0, 0}, {3, 0}, {0, 3}, {3, 3}}) {
                const glm::vec3 corner(patches[k].at(i, j));
                double nearest = 1e30;
                for (const glm::vec3& q : m.positions) nearest = std::min(nearest, double(glm::length(q - corner)));
                ASSERT_LT(nearest, 1e-6) << "patch " << k << " corner " << i << "," << j << " at resolution " << res;
            }
        const mesh::MeshReport r = mesh::check(m);
        EXPECT_EQ(r.nonManifoldEdges, 0u);
        EXPECT_EQ(r.misorientedEdges, 0u) << "patches disagree on their outward side";
        EXPECT_EQ(r.repeatedIndexTriangles + r.zeroAreaTriangles, 0u) << "collapsed triangles at the poles were kept";
        // Open where the spout and handle meet the body (two ends each) and between lid and rim:
        // 16 curves of `res` edges, welded everywhere else.
        EXPECT_EQ(r.boundaryEdges, std::size_t(16 * res)) << "resolution " << res;
        EXPECT_EQ(r.usedVertices, r.vertices);
    }
}

TEST(Teapot, ReaderRejectsBrokenFilesWithTheirPosition) {
    const auto dir = test::scratchDir("bpt");
    std::ifstream in(test::sourceDir() / "data/teapot.bpt");
    const std::string good((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    auto errorOf = [&](const std::string& name, const std::string& text) {
        const auto p = dir / name;
        std::ofstream(p) << text;
        try {
            mesh::readBezierPatches(p);
        } catch (const IoError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    const std::string cut = errorOf("cut.bpt", good.substr(0, good.size() / 2));
    EXPECT_NE(cut.find("cut.bpt:"), std::string::npos) << cut;
    EXPECT_NE(cut.find("unexpected end of file"), std::string::npos) << cut;
    const std::string word = errorOf("word.bpt", "1\n3 3\n1 2 3\n4 five 6\n");
    EXPECT_NE(word.find("word.bpt:4:3: expected y of point 2 of 16 of patch 1 of 1, found 'five'"), std::string::npos)
        << word;
    const std::string huge = errorOf("huge.bpt", "900000\n3 3\n");
    EXPECT_NE(huge.find("900000 patches but is only"), std::string::npos) << huge;
    const std::string degree = errorOf("degree.bpt", "1\n0 3\n" + std::string(16 * 6, ' '));
    EXPECT_NE(degree.find("degree.bpt:2:4: degrees of patch 1 of 1 must be from 1 to 20"), std::string::npos) << degree;
    const std::string extra = errorOf("extra.bpt", good + "3 3\n");
    EXPECT_NE(extra.find("expected the end of the file after 32 patches"), std::string::npos) << extra;
    const std::string nan = errorOf("nan.bpt", "1\n1 1\n0 0 0\n1 0 0\n0 1 nan\n1 1 0\n");
    EXPECT_NE(nan.find("nan.bpt:5:"), std::string::npos) << nan;
    EXPECT_THROW(mesh::readBezierPatches(dir / "missing.bpt"), IoError);
}

TEST(Tessellate, RefusesAbsurdResolutions) {
    const auto patches = mesh::readBezierPatches(test::sourceDir() / "data/teapot.bpt");
    EXPECT_THROW(mesh::tessellate(patches, 0), std::invalid_argument);
    try {
        mesh::tessellate(patches, 4000);
        FAIL() << "no error";
    } catch (const ResourceError& e) {
        EXPECT_NE(std::string(e.what()).find("MiB"), std::string::npos) << e.what();
    }
}
