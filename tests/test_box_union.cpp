// Unions of boxes under translations (implicit/box_union.h): the same bits as the tree of unions and
// translates they replace, exact box bounds, and the meshes of a sponge of cubes.
#include <bit>
#include <cstdint>
#include <random>
#include <string>

#include <tbb/global_control.h>
#include <glm/common.hpp>

#include <gtest/gtest.h>

#include "csg/nodes.h"
#include "csg/scene.h"
#include "implicit/primitives.h"
#include "test_util.h"
#include "volume/sample.h"
#include "volume/surface.h"
#include "volume/vdb_io.h"

using namespace isoforge;
using implicit::Box3;
using implicit::FieldPtr;

namespace {

struct Init {
    Init() { volume::initializeOpenVdb(); }
} init;

std::uint32_t bits(float v) {
    return std::bit_cast<std::uint32_t>(v);
}

/// Random boxes, each under zero to three nested translations; on a lattice of eighths, where
/// many points are as far from one box as from another (ties, which the first box must win).
std::vector<FieldPtr> randomBoxes(std::mt19937& rng, int n, bool lattice) {
    std::uniform_real_distribution<float> size(0.05f, 1.2f), shift(-1.f, 1.f), unit(0.f, 1.f);
    auto draw = [&](std::uniform_real_distribution<float>& d) {
        const float v = d(rng);
        return lattice ? std::max(0.125f, std::round(v * 8.f) / 8.f) : v;
    };
    std::vector<FieldPtr> boxes;
    for (int i = 0; i < n; ++i) {
        const glm::vec3 s(draw(size), draw(size), draw(size));
        const float rounding = !lattice && unit(rng) < 0.3f ? 0.2f * std::min({s.x, s.y, s.z}) : 0.f;
        FieldPtr f = implicit::makeBox(s, rounding);
        for (int k = int(rng() % 4); k > 0; --k)
            f = implicit::makeTranslated(f, {draw(shift), draw(shift), draw(shift)});
        boxes.push_back(f);
    }
    return boxes;
}

/// The union as a tree would give it: the first of the smallest values decides, and gives its gradient.
float reference(const std::vector<FieldPtr>& boxes, const glm::vec3& p, glm::vec3& g) {
    std::size_t win = 0;
    float v = boxes[0]->value(p);
    for (std::size_t i = 1; i < boxes.size(); ++i) {
        const float c = boxes[i]->value(p);
        if (c < v) {
            v = c;
            win = i;
        }
    }
    g = boxes[win]->gradient(p);
    return v;
}

/// A Menger sponge of level 2 as OpenSCAD's example024 builds it: per axis a bar through the middle
/// and 72 thinner bars, each under two translations, the three axes turned about the middle, the
/// whole turned off the axes; with `coloured`, every bar under a colour.
FieldPtr sponge(bool coloured) {
    auto number = [](float v) { return std::to_string(v); };
    auto bar = [&](float thickness, glm::vec2 first, glm::vec2 second) {
        const std::string cube = "cube([10, " + number(thickness) + ", " + number(thickness) + "], center = true);";
        return " translate([0, " + number(first.x) + ", " + number(first.y) + "]) translate([0, " + number(second.x) +
               ", " + number(second.y) + "]) " + (coloured ? "color([0.5, 0.5, 0.5]) " + cube : cube);
    };
    std::string bars;
    for (const char* turn : {"[0, 0, 0]", "[0, 0, 90]", "[0, 90, 0]"}) {
        bars += std::string("rotate(") + turn + ") union() {" + bar(3.f, {0, 0}, {0, 0});
        for (int i = -1; i <= 1; ++i)
            for (int j = -1; j <= 1; ++j)
                for (int k = 0; k < 9; ++k)
                    if (i || j)
                        bars += bar(1.f, {3.f * float(k % 3 - 1), 3.f * float(k / 3 - 1)}, {float(i), float(j)});
        bars += " }";
    }
    return csg::parseScene("rotate([45, 35, 0]) difference() { cube(9, center = true); " + bars + " }", "m.isf").root;
}

}  // namespace

TEST(BoxUnion, TheSameBitsAsTheTreeOfUnionsAndTranslates) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-2.f, 2.f);
    for (int round = 0; round < 4; ++round) {
        const std::vector<FieldPtr> boxes = randomBoxes(rng, 10 + 10 * round, round % 2 == 1);
        // Nested the way OpenSCAD's groups nest them: halves under a translation of zero.
        const std::size_t middle = boxes.size() / 2;
        const FieldPtr inner = implicit::makeTranslated(
            csg::makeUnion({boxes.begin() + std::ptrdiff_t(middle), boxes.end()}), glm::vec3(0.f));
        std::vector<FieldPtr> outer(boxes.begin(), boxes.begin() + std::ptrdiff_t(middle));
        outer.push_back(inner);
        const FieldPtr f = csg::makeUnion(outer);
        EXPECT_EQ(f->describe(), "union(" + std::to_string(boxes.size()) + " boxes)");
        std::vector<glm::vec3> pts;
        for (int i = 0; i < 3000; ++i) {
            // Points on a coarse lattice too: exact ties between boxes and values of zero.
            glm::vec3 p(u(rng), u(rng), u(rng));
            if (i % 3 == 0) p = glm::round(p * 8.f) / 8.f;
            pts.push_back(p);
        }
        std::vector<float> batch(pts.size());
        f->values(pts, batch);
        for (std::size_t i = 0; i < pts.size(); ++i) {
            glm::vec3 g, gRef;
            const float v = f->valueAndGradient(pts[i], g), vRef = reference(boxes, pts[i], gRef);
            ASSERT_EQ(bits(v), bits(vRef)) << i;
            ASSERT_EQ(bits(f->value(pts[i])), bits(vRef)) << i;
            ASSERT_EQ(bits(batch[i]), bits(vRef)) << i;
            for (int k = 0; k < 3; ++k) ASSERT_EQ(bits(g[k]), bits(gRef[k])) << i;
        }
        // Bounds hold every value, and pruning to a box keeps the values there, bit for bit.
        std::uniform_real_distribution<float> h(0.01f, 0.6f);
        for (int i = 0; i < 200; ++i) {
            const glm::vec3 c(u(rng), u(rng), u(rng)), r(h(rng), h(rng), h(rng));
            const Box3 region{c - r, c + r};
            const implicit::Pruned pr = f->prune(region);
            const FieldPtr s = pr.field ? pr.field : f;
            for (int k = 0; k < 50; ++k) {
                const glm::vec3 t = 0.5f + 0.25f * glm::vec3(u(rng), u(rng), u(rng));  // in [0, 1]
                const glm::vec3 p = region.min + (region.max - region.min) * t;
                const float v = f->value(p);
                ASSERT_LE(pr.bound.lo, v);
                ASSERT_GE(pr.bound.hi, v);
                ASSERT_EQ(bits(s->value(p)), bits(v));
                glm::vec3 g, gs;
                f->valueAndGradient(p, g);
                s->valueAndGradient(p, gs);
                ASSERT_EQ(g, gs);
            }
        }
    }
}

TEST(BoxUnion, OnlyRunsOfBoxesAreGrouped) {
    const FieldPtr a = implicit::makeBox(glm::vec3(1.f)), b = implicit::makeTranslated(a, {2, 0, 0});
    const FieldPtr sphere = implicit::makeSphere(0.5f);
    // box, box, sphere, box: the first two become one union of boxes; the last stays alone.
    const FieldPtr u = csg::makeUnion({a, b, sphere, implicit::makeTranslated(a, {0, 3, 0})});
    EXPECT_EQ(u->describe(), "union(3 children)");
    // A difference groups what it subtracts, never its first child.
    const FieldPtr d = csg::makeDifference({a, b, implicit::makeTranslated(a, {0, 0.5f, 0})});
    EXPECT_EQ(d->describe(), "difference(2 children)");
    // A rotation is not a translation: nothing to group.
    const FieldPtr r =
        csg::makeUnion({a, implicit::makeTransformed(a, glm::mat4(glm::mat3(0, 1, 0, -1, 0, 0, 0, 0, 1)))});
    EXPECT_EQ(r->describe(), "union(2 children)");
}

TEST(BoxUnion, ADeepChainOfTranslationsStaysATree) {
    // A recursive module's chain, translate(union(cube, translate(union(cube, ...)))), 300 deep: the boxes
    // under at most kMaxBoxShifts translations are grouped, the rest stays a tree (a union would apply the
    // whole chain once per box and point); the values and gradients are the same bits either way.
    const FieldPtr box = implicit::makeBox(glm::vec3(0.6f, 0.5f, 0.4f));
    const glm::vec3 step(0.37f, 0.11f, -0.05f);
    FieldPtr chain = box;
    std::vector<FieldPtr> boxes{box};  // box k under k translations, each its own field
    for (int k = 1; k < 300; ++k) {
        chain = csg::makeUnion({box, implicit::makeTranslated(chain, step)});
        boxes.push_back(implicit::makeTranslated(boxes.back(), step));
    }
    EXPECT_EQ(chain->describe(), "union(2 children)");
    std::mt19937 rng(2);
    std::uniform_real_distribution<float> u(-1.f, 1.f);
    for (int i = 0; i < 300; ++i) {
        const glm::vec3 p = glm::vec3(0.37f, 0.11f, -0.05f) * float(i) + 0.5f * glm::vec3(u(rng), u(rng), u(rng));
        // Box k is the chain's k-th in its order too (the outermost first): the first of equals decides.
        glm::vec3 g, gRef;
        const float v = chain->valueAndGradient(p, g), vRef = reference(boxes, p, gRef);
        ASSERT_EQ(bits(v), bits(vRef)) << i;
        for (int k = 0; k < 3; ++k) ASSERT_EQ(bits(g[k]), bits(gRef[k])) << i;
    }
}

TEST(BoxUnion, ABoxBoundIsItsExactRange) {
    // The lowest value over a region is the value at the region's point nearest the centre on every
    // axis, the highest at its farthest corner; no point of the region gives less or more.
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-2.f, 2.f), h(0.01f, 1.f);
    const FieldPtr box = implicit::makeBox({1.f, 0.6f, 0.3f}, 0.1f);
    for (int i = 0; i < 500; ++i) {
        const glm::vec3 c(u(rng), u(rng), u(rng)), r(h(rng), h(rng), h(rng));
        const Box3 region{c - r, c + r};
        const implicit::Interval b = box->bound(region);
        const glm::vec3 nearest = glm::clamp(glm::vec3(0.f), region.min, region.max);
        EXPECT_EQ(b.lo, box->value(nearest));
        for (int k = 0; k < 8; ++k) {
            const glm::vec3 corner(k & 1 ? region.max.x : region.min.x, k & 2 ? region.max.y : region.min.y,
                                   k & 4 ? region.max.z : region.min.z);
            EXPECT_LE(box->value(corner), b.hi);
        }
        for (int k = 0; k < 50; ++k) {
            const glm::vec3 p = c + r * glm::vec3(u(rng), u(rng), u(rng)) / 2.f;
            EXPECT_LE(b.lo, box->value(p));
            EXPECT_GE(b.hi, box->value(p));
        }
    }
}

TEST(BoxUnion, ASpongeOfCubesMeshesAsItsTreeDoes) {
    // Sharp: closed, manifold, oriented, no intersecting pair; the same vertices and triangles as with
    // every bar coloured (colours keep the tree of unions as it was), on 1 and 2 threads.
    const FieldPtr plain = sponge(false), coloured = sponge(true);
    volume::SurfaceOptions o;
    o.sharp = true;
    for (float voxel : {0.2f, 0.13f}) {
        volume::SampleOptions so;
        so.voxelSize = voxel;
        mesh::TriMesh reference;
        for (int threads : {1, 2}) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
            const mesh::TriMesh m = volume::meshSurface(*volume::sample(plain, so), plain, o);
            if (threads == 1) {
                reference = m;
                test::expectClosedSurface(m, "sponge at " + std::to_string(voxel));
                const mesh::TriMesh c = volume::meshSurface(*volume::sample(coloured, so), coloured, o);
                EXPECT_EQ(c.positions, m.positions) << voxel;
                EXPECT_EQ(c.triangles, m.triangles) << voxel;
                continue;
            }
            EXPECT_EQ(m.positions, reference.positions) << threads << " threads";
            EXPECT_EQ(m.triangles, reference.triangles) << threads << " threads";
        }
    }
}
