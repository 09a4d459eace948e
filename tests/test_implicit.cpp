#include <array>
#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "core/error.h"
#include "implicit/blobby.h"
#include "implicit/primitives.h"
#include "implicit/quadric.h"
#include "implicit/shape_spec.h"
#include "implicit/tape.h"
#include "test_util.h"

using namespace isoforge;
using namespace isoforge::implicit;

namespace {

std::vector<FieldPtr> allFields() {
    std::vector<FieldPtr> f = {
        makeSphere(0.8f),
        makeBox({1.f, 0.6f, 0.4f}),
        makeBox({1.f, 1.f, 1.f}, 0.2f),
        makeCylinder(0.5f, 1.2f),
        makeCone(0.6f, 0.1f, 1.f),
        makeTorus(0.7f, 0.2f),
        makeCapsule(0.3f, 0.8f),
        makeTetrahedron(0.6f),
        makeEllipsoid({0.9f, 0.5f, 0.3f}),
        makePlane({1.f, 2.f, 3.f}, 0.1f),
        makeTransformed(makeTorus(0.7f, 0.2f), glm::rotate(glm::scale(glm::mat4(1.f), glm::vec3(1.f, 0.5f, 2.f)), 0.7f,
                                                           glm::vec3(1.f, 1.f, 0.f))),
        makeOffset(makeBox({1.f, 1.f, 1.f}), 0.1f),
        makeShell(makeSphere(0.7f), 0.1f),
        makeNamedQuadric("hyperboloid1", 0.5f, 0.5f, 0.7f),
        makeNamedQuadric("ellipsoid", 0.9f, 0.6f, 0.4f),
        makeTapeField(parseExpression("x^4 - 5*x^2 + y^4 - 5*y^2 + z^4 - 5*z^2 + 11.8"), Box3::everything(), "goursat"),
        makeTapeField(
            parseExpression(
                "max(sqrt(x^2+y^2+z^2) - 1, -(abs(z) - 0.3)) + 0.1*sin(5*x)*cos(3*y) + exp(-z)/10 - log(3+x)/10"),
            Box3::everything(), "mixed"),
        makeBlobby({{{0, 0, 0}, 1.f, 1.f}, {{0.8f, 0, 0}, 0.7f, 1.f}}, 0.5f, BlobKernel::Wyvill),
        makeBlobby({{{0, 0, 0}, 0.6f, 1.f}, {{0.8f, 0.2f, 0}, 0.5f, 1.f}}, 0.3f, BlobKernel::Blinn),
        makeBlobby({{{0, 0, 0}, 1.f, 1.f}, {{0.5f, 0.5f, 0}, 0.8f, -0.5f}}, 0.4f, BlobKernel::Metaball),
        makeClipped(makeNamedQuadric("elliptic_cone", 1.f, 1.f, 1.f), {glm::vec3(-1.f), glm::vec3(1.f)}),
    };
    return f;
}

}  // namespace

TEST(Primitives, ExactDistancesMatchAnalyticOnes) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-2.f, 2.f);
    for (int i = 0; i < 2000; ++i) {
        const glm::vec3 p(u(rng), u(rng), u(rng));
        EXPECT_NEAR(makeSphere(0.8f)->value(p), glm::length(p) - 0.8f, 1e-5f);
        // Box: outside, the distance to the clamped point; inside, minus the nearest face distance.
        const glm::vec3 h(0.5f, 0.3f, 0.2f), q = glm::clamp(p, -h, h);
        const bool in = glm::all(glm::lessThan(glm::abs(p), h));
        const float d =
            in ? -std::min({h.x - std::abs(p.x), h.y - std::abs(p.y), h.z - std::abs(p.z)}) : glm::length(p - q);
        EXPECT_NEAR(makeBox(2.f * h)->value(p), d, 1e-5f);
        const float rr = std::sqrt(p.x * p.x + p.y * p.y) - 0.7f;
        EXPECT_NEAR(makeTorus(0.7f, 0.2f)->value(p), std::sqrt(rr * rr + p.z * p.z) - 0.2f, 1e-5f);
        // A rigid motion keeps exact distances.
        const glm::mat4 m =
            glm::rotate(glm::translate(glm::mat4(1.f), glm::vec3(0.3f, -0.2f, 0.1f)), 1.1f, glm::vec3(0, 1, 1));
        EXPECT_NEAR(makeTransformed(makeSphere(0.8f), m)->value(p),
                    glm::length(p - glm::vec3(0.3f, -0.2f, 0.1f)) - 0.8f, 1e-4f);
        // A uniform scale scales distances.
        EXPECT_NEAR(makeTransformed(makeTorus(0.7f, 0.2f), glm::scale(glm::mat4(1.f), glm::vec3(2.f)))->value(p),
                    2.f * makeTorus(0.7f, 0.2f)->value(p / 2.f), 1e-4f);
    }
}

TEST(Primitives, DistanceFieldsNeverOverestimateTheDistance) {
    // For distance fields, |f(p)| <= distance to the surface: check against dense surface points of
    // the zero set, found by bisection along random segments.
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-1.5f, 1.5f);
    for (const FieldPtr& f : allFields()) {
        if (!f->isDistance()) continue;
        std::vector<glm::vec3> surface;
        for (int i = 0; i < 3000 && surface.size() < 400; ++i) {
            glm::vec3 a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng));
            float fa = f->value(a), fb = f->value(b);
            if ((fa < 0) == (fb < 0)) continue;
            for (int k = 0; k < 40; ++k) {
                const glm::vec3 m = 0.5f * (a + b);
                const float fm = f->value(m);
                if ((fm < 0) == (fa < 0)) {
                    a = m;
                    fa = fm;
                } else {
                    b = m;
                }
            }
            surface.push_back(a);
        }
        for (int i = 0; i < 300; ++i) {
            const glm::vec3 p(u(rng), u(rng), u(rng));
            float dist = 1e9f;
            for (const auto& s : surface) dist = std::min(dist, glm::length(p - s));
            EXPECT_LE(std::abs(f->value(p)), dist + 1e-3f) << f->describe();
        }
    }
}

TEST(Fields, BoundsNeverUnderestimateAndBatchesMatchPoints) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-1.5f, 1.5f), s(0.01f, 1.f);
    for (const FieldPtr& f : allFields()) {
        for (int i = 0; i < 200; ++i) {
            const glm::vec3 c(u(rng), u(rng), u(rng)), h(s(rng), s(rng), s(rng));
            const Box3 box{c - h, c + h};
            const Interval b = f->bound(box);
            std::vector<glm::vec3> pts;
            for (int k = 0; k < 64; ++k)
                pts.push_back(box.min + glm::vec3(s(rng), s(rng), s(rng)) * (box.max - box.min));
            std::vector<float> batch(pts.size());
            f->values(pts, batch);
            for (std::size_t k = 0; k < pts.size(); ++k) {
                const float v = f->value(pts[k]);
                ASSERT_NEAR(batch[k], v, 1e-4f * (1.f + std::abs(v))) << f->describe();
                ASSERT_GE(v, b.lo - 1e-4f * (1.f + std::abs(v))) << f->describe();
                ASSERT_LE(v, b.hi + 1e-4f * (1.f + std::abs(v))) << f->describe();
            }
            // Simplified over the box, the field keeps its values there.
            if (FieldPtr g = f->simplify(box)) {
                for (const auto& p : pts) {
                    ASSERT_NEAR(g->value(p), f->value(p), 1e-5f * (1.f + std::abs(f->value(p)))) << f->describe();
                }
            }
        }
    }
}

TEST(Quadrics, ValuesFollowTheirFormulas) {
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u(-2.f, 2.f);
    const std::array<float, 10> k = {1.f, -2.f, 0.5f, 0.3f, 0.f, -0.7f, 1.f, 0.f, -1.5f, 0.25f};
    auto general = makeQuadric(k);
    auto ellipsoid = makeNamedQuadric("ellipsoid", 0.5f, 0.4f, 0.6f);
    auto paraboloid = makeNamedQuadric("hyperbolic_paraboloid", 0.5f, 0.4f);
    for (int i = 0; i < 500; ++i) {
        const glm::vec3 p(u(rng), u(rng), u(rng));
        const float g = k[0] * p.x * p.x + k[1] * p.y * p.y + k[2] * p.z * p.z + k[3] * p.x * p.y + k[4] * p.y * p.z +
                        k[5] * p.z * p.x + k[6] * p.x + k[7] * p.y + k[8] * p.z + k[9];
        EXPECT_NEAR(general->value(p), g, 1e-4f * (1.f + std::abs(g)));
        const float e = p.x * p.x / 0.25f + p.y * p.y / 0.16f + p.z * p.z / 0.36f - 1.f;
        EXPECT_NEAR(ellipsoid->value(p), e, 1e-4f * (1.f + std::abs(e)));
        EXPECT_NEAR(paraboloid->value(p), p.x * p.x / 0.25f - p.y * p.y / 0.16f - p.z, 1e-3f);
    }
}

TEST(Tape, ExpressionsEvaluateLikeCode) {
    auto t = parseExpression("-x^3 + 2*y^-2 - z/4 + min(x, y) * max(1, z) + abs(-3) + pi");
    for (glm::vec3 p : {glm::vec3(0.5f, 1.5f, -2.f), glm::vec3(-1.f, 0.3f, 4.f)}) {
        const float want = -p.x * p.x * p.x + 2.f / (p.y * p.y) - p.z / 4 + std::min(p.x, p.y) * std::max(1.f, p.z) +
                           3.f + 3.14159265f;
        EXPECT_NEAR(t->eval(p), want, 1e-4f * std::abs(want));
    }
    EXPECT_NEAR(parseExpression("2^10")->eval(glm::vec3(0.f)), 1024.f, 1e-3f);
    EXPECT_NEAR(parseExpression("-2^2")->eval(glm::vec3(0.f)), -4.f, 1e-6f);
}

TEST(Tape, PruningDropsTheBranchesThatCannotWinAndKeepsValues) {
    // A union of 200 small spheres along x: near one end, the tape shrinks to a few spheres.
    std::string e = "sqrt((x)^2 + y^2 + z^2) - 0.1";
    for (int i = 1; i < 200; ++i) e = "min(" + e + ", sqrt((x - " + std::to_string(i * 0.3) + ")^2 + y^2 + z^2) - 0.1)";
    auto t = parseExpression(e);
    const Box3 box{glm::vec3(-0.2f), glm::vec3(0.2f)};
    auto s = t->simplify(box);
    ASSERT_TRUE(s);
    EXPECT_LT(s->size() * 20, t->size());
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-0.2f, 0.2f);
    for (int i = 0; i < 100; ++i) {
        const glm::vec3 p(u(rng), u(rng), u(rng));
        EXPECT_FLOAT_EQ(s->eval(p), t->eval(p));
    }
    EXPECT_LE(s->registers(), t->registers());
}

TEST(Tape, PruningTakesNestedMinsAsOneUnionOfTheirLeaves) {
    // The same union, and a box of one unit around sphere 100 (x = 30): a few spheres reach into it.
    // Pairwise, min(min(..., s97), s98) keeps both sides (the far prefix's lowest value overlaps
    // s98's range over so large a box) and with them the whole prefix; as one 200-way min, every
    // sphere whose lowest value exceeds the lowest highest value among all of them is dropped.
    std::string e = "sqrt((x)^2 + y^2 + z^2) - 0.1";
    for (int i = 1; i < 200; ++i) e = "min(" + e + ", sqrt((x - " + std::to_string(i * 0.3) + ")^2 + y^2 + z^2) - 0.1)";
    auto t = parseExpression(e);
    const Box3 box{glm::vec3(29.5f, -0.5f, -0.5f), glm::vec3(30.5f, 0.5f, 0.5f)};
    Interval bound;
    auto s = t->simplify(box, &bound);
    ASSERT_TRUE(s);
    EXPECT_LT(s->size() * 10, t->size()) << s->size() << " of " << t->size();
    EXPECT_EQ(bound.lo, t->eval(box).lo);
    EXPECT_EQ(bound.hi, t->eval(box).hi);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-0.5f, 0.5f);
    for (int i = 0; i < 200; ++i) {
        const glm::vec3 p = box.centre() + glm::vec3(u(rng), u(rng), u(rng));
        EXPECT_EQ(s->eval(p), t->eval(p));
    }
    // A max of mins and a min used twice (not a tree's inner node) keep their values too.
    auto m = parseExpression("max(min(min(x, y), z), -min(min(x, y), 2)) + min(min(x, y), 2)");
    const Box3 b2{glm::vec3(0.5f, 3.f, 4.f), glm::vec3(1.f, 3.5f, 5.f)};
    if (auto ms = m->simplify(b2))
        for (int i = 0; i < 50; ++i) {
            const glm::vec3 p = b2.centre() + 0.25f * glm::vec3(u(rng), u(rng), u(rng));
            EXPECT_EQ(ms->eval(p), m->eval(p));
        }
}

TEST(Tape, LipschitzBoundsFollowTheStructure) {
    const float inf = std::numeric_limits<float>::infinity();
    auto L = [](const char* e) { return parseExpression(e)->lipschitz(); };
    // Norms of affine vectors: their Jacobian's largest singular value, not the looser Frobenius norm.
    EXPECT_NEAR(L("sqrt(x^2 + y^2 + z^2) - 0.5"), 1.f, 1e-5f);
    EXPECT_NEAR(L("sqrt((2*x)^2 + y^2 + z^2) - 1"), 2.f, 1e-5f);
    EXPECT_NEAR(L("sqrt((x/2)^2 + (y - 3)^2 + z^2 + 0.25) - 1"), 1.f, 1e-5f);
    EXPECT_NEAR(L("sqrt((0.6*x + 0.8*y)^2 + (0.8*x - 0.6*y)^2 + z^2)"), 1.f, 1e-5f);  // a rotation
    EXPECT_NEAR(L("sqrt((x + y)^2 + (x - y)^2)"), std::sqrt(2.f), 1e-5f);
    // min, max, abs, neg, sums, scalings, sin and cos; constants have none.
    EXPECT_NEAR(L("max(abs(x), max(abs(y), abs(z))) - 1"), 1.f, 1e-5f);
    EXPECT_NEAR(L("-min(sqrt(x^2 + y^2) - 1, 2*z)"), 2.f, 1e-5f);
    EXPECT_NEAR(L("abs(x) + abs(y)"), 2.f, 1e-5f);
    EXPECT_NEAR(L("sin(3*x) / 2"), 1.5f, 1e-5f);
    EXPECT_NEAR(L("sqrt(abs(x)^2 + y^2)"), std::sqrt(2.f), 1e-5f);  // a non-affine term: its bound squared
    EXPECT_EQ(L("2 + 3 * 4"), 0.f);
    // No bound: products of variables, squares alone, exp and log, roots of what may reach 0 steeply.
    for (const char* e : {"x * y", "x^2 + y^2 - 1", "exp(x)", "log(2 + x)", "sqrt(x^2 - 1)", "sqrt(abs(x))", "x / y",
                          "x^4 - 5*x^2 + y^4 - 5*y^2 + z^4 - 5*z^2 + 11.8"})
        EXPECT_EQ(L(e), inf) << e;
    // As fields: a tape's bound; distance fields 1, the others none.
    EXPECT_NEAR(makeTapeField(parseExpression("sqrt(x^2 + y^2 + z^2) - 1"), Box3::everything(), "s")->gradientBound(),
                1.f, 1e-5f);
    EXPECT_EQ(makeSphere(1.f)->gradientBound(), 1.f);
    EXPECT_EQ(makeBlobby({{{0, 0, 0}, 1.f, 1.f}}, 0.5f, BlobKernel::Wyvill)->gradientBound(), inf);
}

TEST(Tape, LipschitzBoundsHoldOnRealModels) {
    // |f(p) - f(q)| <= L |p - q| between random nearby points: the generated text model (8,000
    // statements: strokes and rings by sub, square, sqrt, abs, min, max) and a union of balls.
    std::string balls = "sqrt(x^2 + y^2 + z^2) - 0.1";
    for (int i = 1; i < 50; ++i)
        balls = "min(" + balls + ", sqrt((x - " + std::to_string(0.03 * i) + ")^2 + (y + " + std::to_string(0.02 * i) +
                ")^2 + z^2) - " + std::to_string(0.05 + 0.002 * i) + ")";
    const std::vector<std::shared_ptr<const Tape>> tapes = {
        readVmFile((test::sourceDir() / "data" / "text.vm").string()), parseExpression(balls)};
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-1.f, 1.f), small(-0.02f, 0.02f);
    for (const auto& t : tapes) {
        const float L = t->lipschitz();
        ASSERT_TRUE(std::isfinite(L));
        EXPECT_GE(L, 1.f);
        float steepest = 0.f;
        for (int i = 0; i < 4000; ++i) {
            const glm::vec3 p(u(rng), u(rng), u(rng)), q = p + glm::vec3(small(rng), small(rng), small(rng));
            const float d = glm::length(p - q);
            if (d < 1e-4f) continue;
            const float slope = std::abs(t->eval(p) - t->eval(q)) / d;
            steepest = std::max(steepest, slope);
            EXPECT_LE(slope, L * 1.001f + 1e-3f) << "at " << p.x << " " << p.y << " " << p.z;
        }
        EXPECT_GT(steepest, 0.5f * L) << "the bound should be near the steepest slope found";
    }
}

TEST(Tape, ExpressionErrorsGiveTheColumn) {
    auto err = [](const char* text) {
        try {
            parseExpression(text);
        } catch (const ParseError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_NE(err("x^2 +").find("expression:1:6:"), std::string::npos) << err("x^2 +");
    EXPECT_NE(err("x^0.5").find("integer exponent"), std::string::npos) << err("x^0.5");
    EXPECT_NE(err("foo(x)").find("unknown name 'foo'"), std::string::npos);
    EXPECT_NE(err("min(x)").find("two arguments"), std::string::npos);
    EXPECT_NE(err("(x + y").find("expected ')'"), std::string::npos);
    EXPECT_NE(err("x y").find("expression:1:3:"), std::string::npos) << err("x y");
    EXPECT_NE(err("").find("found nothing"), std::string::npos);
    // fuzz_expression's finding: 4,000 signs in a row overflowed the stack (read recursively). Runs of signs
    // now read in a loop, and nesting is bounded.
    const std::string signs = "x^4 -" + std::string(100000, '+') + "-" + std::string(100001, '-') + "y";
    const auto tape = parseExpression(signs);
    EXPECT_EQ(tape->eval(glm::vec3(1.f, 2.f, 3.f)), 1.f - 2.f);
    EXPECT_NE(err((std::string(600, '(') + "x" + std::string(600, ')')).c_str()).find("nested more than 500 deep"),
              std::string::npos);
    EXPECT_NE(err((std::string(300, '-') + "sin(" + std::string(550, '(') + "x").c_str()).find("nested"),
              std::string::npos);
}

TEST(Tape, VmFilesReadAndFailWithLineAndColumn) {
    const std::string sphere =
        "# a sphere of radius 0.5\n_0 var-x\n_1 var-y\n_2 var-z\n_3 square _0\n_4 square _1\n"
        "_5 square _2\n_6 add _3 _4\n_7 add _6 _5\n_8 sqrt _7\n_9 const 0.5\n_a sub _8 _9\n";
    auto t = parseVm(sphere, "sphere.vm");
    EXPECT_NEAR(t->eval(glm::vec3(1.f, 0.f, 0.f)), 0.5f, 1e-6f);
    EXPECT_NEAR(t->eval(glm::vec3(0.f)), -0.5f, 1e-6f);
    auto err = [](const std::string& text) {
        try {
            parseVm(text, "m.vm");
        } catch (const ParseError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_NE(err("_0 var-x\n_1 frobnicate _0\n").find("m.vm:2:4: unknown op 'frobnicate'"), std::string::npos);
    EXPECT_NE(err("_0 var-x\n_1 add _0 _9\n").find("m.vm:2:11: unknown id '_9'"), std::string::npos)
        << err("_0 var-x\n_1 add _0 _9\n");
    EXPECT_NE(err("_0 var-x\n_1 add _0\n").find("m.vm:2:4: 'add' takes 2 arguments, found 1"), std::string::npos);
    EXPECT_NE(err("_0 const 1.5x\n").find("m.vm:1:10: expected a number"), std::string::npos);
    EXPECT_NE(err("_0 var-x\n_0 var-y\n").find("defined twice"), std::string::npos);
    EXPECT_NE(err("# nothing\n").find("at least one statement"), std::string::npos);
    EXPECT_NE(err("_0\n").find("m.vm:1:1"), std::string::npos);
}

TEST(Shapes, SpecsParseAndFailClearly) {
    EXPECT_NEAR(parseShape("torus(R=1, r=0.3)")->value(glm::vec3(1.3f, 0.f, 0.f)), 0.f, 1e-6f);
    EXPECT_NEAR(parseShape("box(2, 1, 0.5)")->value(glm::vec3(0.f)), -0.25f, 1e-6f);
    EXPECT_NEAR(parseShape("sphere")->value(glm::vec3(0.f)), -1.f, 1e-6f);
    EXPECT_NO_THROW(parseShape("quadric(type=hyperboloid2, a=1, b=1, c=0.5)"));
    EXPECT_THROW(parseShape("blob(1)"), ParseError);
    EXPECT_THROW(parseShape("torus(R=1, q=2)"), ParseError);
    EXPECT_THROW(parseShape("sphere(r=-1)"), ParseError);
    EXPECT_THROW(parseShape("sphere(1, 2)"), ParseError);
    EXPECT_THROW(parseShape("quadric(type=banana)"), ParseError);
    EXPECT_THROW(parseShape("torus(R=1"), ParseError);
}
