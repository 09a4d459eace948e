#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <random>

#include <tbb/global_control.h>
#include <glm/common.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <gtest/gtest.h>

#include "core/error.h"
#include "csg/nodes.h"
#include "csg/scene.h"
#include "csg/shapes.h"
#include "implicit/primitives.h"
#include "mesh/io.h"
#include "mesh/simplify.h"
#include "test_util.h"
#include "volume/marching_cubes.h"
#include "volume/sample.h"
#include "volume/sharpen.h"
#include "volume/surface.h"
#include "volume/vdb_io.h"

using namespace isoforge;

namespace {
struct Init {
    Init() { volume::initializeOpenVdb(); }
} init;

mesh::TriMesh meshOf(const implicit::FieldPtr& f, float voxel) {
    volume::SampleOptions o;
    o.voxelSize = voxel;
    return volume::extractIsosurface(*volume::sample(f, o));
}
mesh::MeshReport meshScene(const implicit::FieldPtr& f, float voxel) {
    return test::expectClosedSurface(meshOf(f, voxel), f->describe());
}
std::string errorOf(const std::string& text) {
    try {
        csg::parseScene(text, "s.isf");
    } catch (const ParseError& e) {
        return e.what();
    }
    return "no error";
}
/// The warnings of a scene that parses, one per line.
std::string warningsOf(const std::string& text) {
    std::string all;
    for (const auto& w : csg::parseScene(text, "s.isf").warnings) all += w.loc.toString() + ": " + w.message + "\n";
    return all;
}
double meshVolume(const std::string& text, float voxel) {
    const auto scene = csg::parseScene(text, "v.isf");
    return meshScene(scene.root, voxel).volume;
}
}  // namespace

TEST(Csg, VolumesOfBooleansMatchAnalyticValues) {
    // Cube (edge 2) minus a sphere of radius 1 at a corner: 8 - pi/6.
    auto cube = implicit::makeBox(glm::vec3(2.f));
    auto ball = implicit::makeTranslated(implicit::makeSphere(1.f), glm::vec3(1.f));
    auto r = meshScene(csg::makeDifference({cube, ball}), 0.01f);
    EXPECT_NEAR(r.volume, 8.0 - M_PI / 6.0, 0.005 * 7.48);
    // Steinmetz solids: two cylinders 16/3 r^3, three 8 (2 - sqrt 2) r^3.
    auto cx = implicit::makeTransformed(
        implicit::makeCylinder(1.f, 4.f),
        glm::mat4(glm::vec4(0, 0, 1, 0), glm::vec4(0, 1, 0, 0), glm::vec4(-1, 0, 0, 0), glm::vec4(0, 0, 0, 1)));
    auto cy = implicit::makeTransformed(
        implicit::makeCylinder(1.f, 4.f),
        glm::mat4(glm::vec4(1, 0, 0, 0), glm::vec4(0, 0, 1, 0), glm::vec4(0, -1, 0, 0), glm::vec4(0, 0, 0, 1)));
    auto cz = implicit::makeCylinder(1.f, 4.f);
    r = meshScene(csg::makeIntersection({cx, cz}), 0.01f);
    EXPECT_NEAR(r.volume, 16.0 / 3.0, 0.005 * 5.33);
    r = meshScene(csg::makeIntersection({cx, cy, cz}), 0.01f);
    EXPECT_NEAR(r.volume, 8.0 * (2.0 - std::sqrt(2.0)), 0.005 * 4.69);
    // Union of overlapping spheres and a smooth union: closed, one component, the blend adds volume.
    auto a = implicit::makeTranslated(implicit::makeSphere(0.5f), glm::vec3(-0.45f, 0, 0));
    auto b = implicit::makeTranslated(implicit::makeSphere(0.5f), glm::vec3(0.45f, 0, 0));
    const auto hard = meshScene(csg::makeUnion({a, b}), 0.01f);
    const auto soft = meshScene(csg::makeUnion({a, b}, 0.3f), 0.01f);
    EXPECT_EQ(soft.components, 1u);
    EXPECT_GT(soft.volume, hard.volume);
    meshScene(csg::makeIntersection({a, b}, 0.2f), 0.01f);
    meshScene(csg::makeDifference({a, b}, 0.2f), 0.01f);
}

TEST(Csg, PruningKeepsValuesAndDropsFarChildren) {
    std::vector<implicit::FieldPtr> kids;
    for (int i = 0; i < 100; ++i)
        kids.push_back(implicit::makeTranslated(implicit::makeSphere(0.2f), glm::vec3(i * 1.f, 0, 0)));
    auto u = csg::makeUnion(kids);
    const implicit::Box3 box{glm::vec3(-0.1f), glm::vec3(0.1f)};
    auto s = u->simplify(box);
    ASSERT_TRUE(s);
    for (float x = -0.1f; x <= 0.1f; x += 0.02f)
        EXPECT_FLOAT_EQ(s->value(glm::vec3(x, 0.1f, 0)), u->value(glm::vec3(x, 0.1f, 0)));
    EXPECT_EQ(s->describe(), kids[0]->describe());  // only the one sphere is left
}

namespace {
/// A sphere that counts the bounds asked of it.
class CountingSphere final : public implicit::Field {
public:
    explicit CountingSphere(std::atomic<int>& bounds) : s_(implicit::makeSphere(0.3f)), bounds_(bounds) {}
    float value(const glm::vec3& p) const override { return s_->value(p); }
    implicit::Interval bound(const implicit::Box3& b) const override {
        ++bounds_;
        return s_->bound(b);
    }
    implicit::Box3 bounds() const override { return s_->bounds(); }
    std::string describe() const override { return "counting sphere"; }

private:
    implicit::FieldPtr s_;
    std::atomic<int>& bounds_;
};
}  // namespace

TEST(Csg, PruningWalksNestedGroupsOnceAndKeepsBoundsAndValues) {
    // OpenSCAD's exports nest groups and transforms deeply (a Menger sponge: 8 levels around 220
    // cubes). Pruning a box asks each leaf for its bound once, not once per level above it, and
    // gives the same bound as bound() and the same values as the whole tree.
    std::atomic<int> asked{0};
    std::function<implicit::FieldPtr(int, glm::vec3)> tree = [&](int depth, glm::vec3 at) -> implicit::FieldPtr {
        if (depth == 0) return implicit::makeTranslated(std::make_shared<CountingSphere>(asked), at);
        const float step = float(1 << depth) * 0.25f;
        std::vector<implicit::FieldPtr> kids{tree(depth - 1, at), tree(depth - 1, at + glm::vec3(step, 0, 0))};
        auto u = csg::makeUnion(kids);
        if (depth % 2) u = csg::makeColored(u, glm::vec4(1, 0, 0, 1));
        return implicit::makeTranslated(u, glm::vec3(0, 0.01f * depth, 0));
    };
    const implicit::FieldPtr whole =
        csg::makeDifference({implicit::makeBox(glm::vec3(40, 2, 2)), tree(7, glm::vec3(0))});
    for (float x : {0.f, 3.3f, 17.f}) {
        const implicit::Box3 box{glm::vec3(x, -0.5f, -0.5f), glm::vec3(x + 1.f, 0.5f, 0.5f)};
        const implicit::Interval b = whole->bound(box);
        asked = 0;
        const implicit::Pruned p = whole->prune(box);
        EXPECT_EQ(asked.load(), 128)
            << x;  // each of the 128 leaves once (bound, then simplify, walked it again per level)
        EXPECT_EQ(p.bound.lo, b.lo);
        EXPECT_EQ(p.bound.hi, b.hi);
        ASSERT_TRUE(p.field);
        for (float t = 0; t <= 1.f; t += 0.05f) {
            const glm::vec3 q = glm::mix(box.min, box.max, glm::vec3(t, 1 - t, t * t));
            EXPECT_EQ(p.field->value(q), whole->value(q)) << x << " " << t;
            EXPECT_EQ(p.field->colorAt(q), whole->colorAt(q)) << x << " " << t;
        }
    }
    EXPECT_TRUE(whole->hasMaterial());
    EXPECT_FALSE(
        csg::makeUnion({implicit::makeSphere(1.f), implicit::makeTranslated(implicit::makeSphere(1.f), glm::vec3(1))})
            ->hasMaterial());
}

/// Central differences of a field's values, 1e-3 apart.
static glm::vec3 centralDifference(const implicit::Field& f, const glm::vec3& p) {
    glm::vec3 d;
    for (int k = 0; k < 3; ++k) {
        glm::vec3 a = p, b = p;
        a[k] += 1e-3f;
        b[k] -= 1e-3f;
        d[k] = (f.value(a) - f.value(b)) / 2e-3f;
    }
    return d;
}

TEST(Csg, GradientsAreTheActiveBranchsOwn) {
    // sharpen() takes its Hermite normals from Field::gradient: at a crease the child that decides the
    // value gives its own normal, where central differences across the crease mix the two faces.
    const auto scene = csg::parseScene(
        "rotate([0, 0, 30]) difference() { cube([2, 2, 2], center = true); translate([1, 1, 1]) sphere(r = 0.8); }",
        "g.isf");
    const glm::mat3 turn(glm::rotate(glm::mat4(1.f), glm::radians(30.f), glm::vec3(0, 0, 1)));
    auto world = [&](glm::vec3 p) { return turn * p; };
    // On the cube's +x face, a hair from the edge it shares with the +y face: the +x normal.
    glm::vec3 g = scene.root->gradient(world(glm::vec3(1.f, 0.999999f, 0.f)));
    EXPECT_NEAR(glm::distance(g, world(glm::vec3(1, 0, 0))), 0.f, 1e-5f);
    g = scene.root->gradient(world(glm::vec3(0.999999f, 1.f, 0.f)));
    EXPECT_NEAR(glm::distance(g, world(glm::vec3(0, 1, 0))), 0.f, 1e-5f);
    // In the sphere's bite, the subtracted sphere's inward normal.
    const glm::vec3 c(1, 1, 1), q = c - glm::normalize(glm::vec3(1, 1, 1)) * 0.8f;
    g = scene.root->gradient(world(q));
    EXPECT_NEAR(glm::distance(g, world(glm::normalize(glm::vec3(1, 1, 1)))), 0.f, 1e-4f);
    // Away from creases the same as central differences, through transforms and scales.
    const auto scaled = csg::parseScene("scale([2, 1, 0.5]) rotate([10, 20, 30]) sphere(r = 1);", "s.isf");
    for (const glm::vec3 p : {glm::vec3(1.5f, 0.2f, 0.1f), glm::vec3(-0.3f, 0.8f, -0.2f)}) {
        const glm::vec3 a = scaled.root->gradient(p);
        const glm::vec3 d = centralDifference(*scaled.root, p);
        EXPECT_NEAR(glm::distance(a, d), 0.f, 2e-3f) << p.x;
    }
}

TEST(Csg, ValueAndGradientWalkOnceAndAgreeWithValue) {
    // valueAndGradient is value() and gradient() from one walk: nested booleans of exact children
    // (boxes, spheres, polyhedra) give both at once, faceted ones (central differences) their value
    // and, when they decide, their gradient. The value must be value()'s to the bit, the gradient
    // the deciding leaf's own.
    const auto scene = csg::parseScene(R"(
        difference() {
            union() {
                rotate([0, 0, 20]) cube([2, 2, 2], center = true);
                translate([1.2, 0, 0]) union() { sphere(r = 0.7); cylinder(h = 3, r = 0.3, center = true, $fn = 12); }
                translate([-1, -1, 0]) polyhedron(points = [[0,0,0],[1,0,0],[0,1,0],[0,0,1]],
                                                  faces = [[0,1,2],[0,3,1],[0,2,3],[1,3,2]]);
            }
            intersection() { sphere(r = 0.9); translate([0, 0, 0.8]) cube(1, center = true); }
        }
    )",
                                       "vg.isf");
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-2.f, 2.f);
    int away = 0;
    for (int i = 0; i < 2000; ++i) {
        const glm::vec3 p(u(rng), u(rng), u(rng));
        glm::vec3 g(0.f);
        const float v = scene.root->valueAndGradient(p, g);
        ASSERT_EQ(v, scene.root->value(p)) << p.x << " " << p.y << " " << p.z;
        ASSERT_EQ(g, scene.root->gradient(p));
        // Away from creases (where a nudge keeps the deciding child) the same as central differences.
        const glm::vec3 d = centralDifference(*scene.root, p);
        if (glm::distance(glm::length(d), 1.f) > 1e-2f) continue;  // a crease within 1e-3, or inside a box's corner
        ++away;
        EXPECT_NEAR(glm::distance(g, d), 0.f, 2e-2f) << p.x << " " << p.y << " " << p.z;
    }
    EXPECT_GT(away, 1000);
}

TEST(Scene, LanguageConstructsAndColours) {
    const auto s = csg::parseScene(R"(
        // comment
        r = 2; h = r * 3;
        camera(eye = [10, -10, 8], target = [0, 0, 0], fov = 35);
        light(direction = [-1, -1, -2]);
        background(top = [1, 1, 1], bottom = [0.5, 0.5, 0.5]);
        color("red") difference() {
            cube(size = [4, 4, 4], center = true);
            cylinder(h = h, r = 1, center = true);
        }
        translate([10, 0, 0]) color([0, 0, 1]) sphere(d = 2 * r);
        %sphere(100);       /* background: not part of the result */
        *cube(100);         // disabled
    )",
                                   "s.isf");
    EXPECT_TRUE(s.camera.given);
    EXPECT_FLOAT_EQ(s.camera.fov, 35.f);
    EXPECT_EQ(s.lights.size(), 1u);
    EXPECT_EQ(s.primitives, 3u);
    EXPECT_NEAR(s.root->value(glm::vec3(10, 0, 0)), -2.f, 1e-5f);
    EXPECT_GT(s.root->value(glm::vec3(0, 0, 0)), 0.f);  // drilled
    EXPECT_EQ(s.root->colorAt(glm::vec3(2, 0, 0)), glm::vec4(1, 0, 0, 1));
    EXPECT_EQ(s.root->colorAt(glm::vec3(10, 2, 0)), glm::vec4(0, 0, 1, 1));
    EXPECT_LT(s.root->bounds().max.x, 13.f);  // the % and * objects are not there
    // $fn = 6 is a hexagonal prism: a vertex on +x at the circumradius, a flat side on +y.
    const auto hex = csg::parseScene("cylinder(h = 2, r = 1, center = true, $fn = 6);", "h.isf");
    EXPECT_NEAR(hex.root->value(glm::vec3(1, 0, 0)), 0.f, 1e-5f);
    EXPECT_NEAR(hex.root->value(glm::vec3(0, std::sqrt(3.f) / 2, 0)), 0.f, 1e-5f);
    // ! makes one subtree the whole result.
    const auto bang = csg::parseScene("cube(1); !translate([5, 0, 0]) sphere(1);", "b.isf");
    EXPECT_GT(bang.root->value(glm::vec3(0.5f)), 0.f);
    // A difference that removes nothing is a warning pointing at its line.
    const auto w = csg::parseScene("\ndifference() { cube(1); translate([9, 0, 0]) cube(1); }", "w.isf");
    ASSERT_EQ(w.warnings.size(), 1u);
    EXPECT_EQ(w.warnings[0].loc.line, 2);
    // So does an intersection whose child lies outside the clipping box.
    const auto clip = csg::parseScene("\n\nintersection() { cube(2); translate([5, 0, 0]) sphere(1); }", "c.isf");
    ASSERT_EQ(clip.warnings.size(), 1u);
    EXPECT_EQ(clip.warnings[0].loc.line, 3);
    EXPECT_NE(clip.warnings[0].message.find("intersection is empty"), std::string::npos);
}

TEST(Scene, ErrorsNameFileLineColumnWithACaretAndSeveralAtOnce) {
    std::string e = errorOf("cube(1);\nsphere(r = );\n");
    EXPECT_NE(e.find("s.isf:2:12: expected a value"), std::string::npos) << e;
    EXPECT_NE(e.find("\n  sphere(r = );\n             ^"), std::string::npos) << e;
    e = errorOf("roof() square(1);\nprojection() { cube(1); }\n");
    EXPECT_NE(e.find("s.isf:1:1: 'roof' is not supported"), std::string::npos) << e;
    EXPECT_NE(e.find("s.isf:2:1: 'projection' is not supported"), std::string::npos) << e;
    EXPECT_NE(e.find("2 errors"), std::string::npos) << e;
    EXPECT_NE(errorOf("frobnicate(1);").find("unknown module 'frobnicate'"), std::string::npos);
    EXPECT_NE(errorOf("cube(size = q);").find("unknown variable 'q'"), std::string::npos);
    EXPECT_NE(errorOf("cube(1)").find("expected"), std::string::npos);
    EXPECT_NE(errorOf("union() { cube(1);").find("'}'"), std::string::npos);
    EXPECT_NE(errorOf("color(\"nocolour\") cube(1);").find("unknown colour"), std::string::npos);
    EXPECT_NE(errorOf("x = \"abc;").find("string not closed"), std::string::npos);
    EXPECT_NE(errorOf("/* open").find("comment not closed"), std::string::npos);
    EXPECT_NE(errorOf("module m() {}").find("'module' is not supported"), std::string::npos);
    // Hostile inputs: deep nesting, long operator chains, absurd $fn, devices as files, long lines.
    std::string deep;
    for (int i = 0; i < 5000; ++i) deep += "union() {";
    EXPECT_NE(errorOf(deep).find("nesting deeper than 256 levels"), std::string::npos);
    EXPECT_NE(errorOf("x = " + std::string(20000, '-') + "1;").find("nesting deeper than 256 levels"),
              std::string::npos);
    std::string chain = "x = 1";
    for (int i = 0; i < 20000; ++i) chain += "+1";
    e = errorOf(chain + ";");
    EXPECT_NE(e.find("expression deeper than 256 levels"), std::string::npos);
    EXPECT_LT(e.size(), 400u) << "long lines are cut around the column";
    EXPECT_NE(errorOf("sphere(1, $fn = 1e30);").find("more than 10,000 sides"), std::string::npos);
    EXPECT_NE(errorOf("vm(\"/dev/zero\");").find("not a regular file"), std::string::npos);
    // Found by fuzzing: a NaN control point (`0 % 0`) reached the tessellation's welding (UB).
    e = errorOf("x = 1;\nnurbs(degree = [1, 1], points = [[[0, 0, 0], [1, 0, 0]], [[0, 1, 0 % 0], [1, 1, 0]]]);\n");
    EXPECT_NE(e.find("s.isf:2:24: nurbs(): control point 3 of 4 is not finite"), std::string::npos) << e;
    // A degree past int's range (undefined when converted) or of 10^9 (knots for it: 8 GB) is refused first.
    for (const char* degree : {"1e30", "1e9", "21", "0.5"}) {
        e = errorOf(std::string("nurbs(degree = [") + degree +
                    ", 1], points = [[[0, 0, 0], [1, 0, 0]], [[0, 1, 0], [1, 1, 0]]]);\n");
        EXPECT_NE(e.find("nurbs() degrees must be from 1 to 20"), std::string::npos) << degree << ": " << e;
    }
}

TEST(Scene, RealOpenScadExportsMatchOpenScadsOwnMeshes) {
    const auto dir = test::sourceDir() / "tests/data/openscad";
    struct Ref {
        const char* name;
        std::size_t components;
        long long genus;
        double volume;
        float voxel;
    };
    // See tests/data/openscad/REFERENCES.txt: OpenSCAD's STL at $fn = 96.
    for (const Ref& ref :
         {Ref{"CSG", 3, 5, 7824.318, 0.2f}, Ref{"steinmetz", 1, 0, 4681.275, 0.15f}, Ref{"hexnut", 1, 1, 1450.59, 0.1f},
          Ref{"extrude", 3, 0, 2821.659, 0.1f}, Ref{"logo", 1, 5, 18686.22, 0.3f}}) {
        const csg::Scene s = csg::readScene((dir / (std::string(ref.name) + ".csg")).string());
        const auto r = meshScene(s.root, ref.voxel);
        EXPECT_EQ(r.components, ref.components) << ref.name;
        EXPECT_EQ(r.genus().value_or(-1), ref.genus) << ref.name;
        EXPECT_NEAR(r.volume, ref.volume, 0.005 * ref.volume) << ref.name;
    }
    // OpenSCAD's rotate_extrude example has text() in it: drawn with OpenSCAD's font libraries now.
    const csg::Scene withText = csg::readScene((dir / "rotate_extrude.csg").string());
    EXPECT_FALSE(withText.root->bounds().isEmpty());
    EXPECT_NE(withText.tree.find("text"), std::string::npos) << withText.tree;
}

TEST(Scene, ExtrusionsTwistScaleAndPartialRevolution) {
    // A twist keeps every cross-section's area: the volume is area * height; scale 0 makes a pyramid.
    auto vol = [](const std::string& text, float voxel) {
        return meshScene(csg::parseScene(text, "e.isf").root, voxel).volume;
    };
    EXPECT_NEAR(vol("linear_extrude(height = 2, twist = 180) square(1, center = true);", 0.01f), 2.0, 0.01);
    EXPECT_NEAR(vol("linear_extrude(height = 3, scale = 0) square(2, center = true);", 0.01f), 4.0, 0.02);
    // A quarter of a torus (tube radius 0.25 at radius 1): pi^2 R r^2 / 2.
    const double torus = 2 * M_PI * M_PI * 1.0 * 0.0625;
    EXPECT_NEAR(vol("rotate_extrude(angle = 90) translate([1, 0]) circle(r = 0.25);", 0.01f), torus / 4, 0.01 * torus);
    EXPECT_NEAR(vol("rotate_extrude(angle = -270) translate([1, 0]) circle(r = 0.25);", 0.01f), 0.75 * torus,
                0.01 * torus);
    // The quarter lies in the first quadrant (counter-clockwise from +x).
    const auto q = csg::parseScene("rotate_extrude(angle = 90) translate([1, 0]) circle(r = 0.25);", "q.isf");
    EXPECT_LT(q.root->value(glm::vec3(0.7071f, 0.7071f, 0)), 0.f);
    EXPECT_GT(q.root->value(glm::vec3(-0.7071f, 0.7071f, 0)), 0.f);
}

TEST(Scene, MeshAndVolumeStatementsReadRealFiles) {
    // The cow (closed, 5,804 triangles, one pinched vertex) as a solid: its volume is the mesh's own.
    const auto cowFile = test::sharedData() / "meshes/cow/cow.obj";
    const auto cow = csg::parseScene("mesh(\"" + cowFile.string() + "\");", "c.isf");
    EXPECT_TRUE(cow.warnings.empty());
    const auto r = meshScene(cow.root, 0.03f);
    EXPECT_NEAR(r.volume, 53.48682, 0.01 * 53.48682);
    // A level-set .vdb cut in half by a box: half a sphere of radius 3.
    const auto sphere = test::sourceDir() / "data/sphere.vdb";
    const auto halfBall = csg::parseScene("intersection() { volume(\"" + sphere.string() +
                                              "\", iso = 0); translate([0, 0, -5]) cube(10, center = true); }",
                                          "h.isf");
    EXPECT_NEAR(meshScene(halfBall.root, 0.03f).volume, 2.0 / 3.0 * M_PI * 27.0, 0.01 * 56.55);
    // The open bunny is accepted with a warning on its line.
    const auto bunny =
        csg::parseScene("\nmesh(\"" + (test::sharedData() / "meshes/bunny/bunny.ply").string() + "\");", "b.isf");
    ASSERT_EQ(bunny.warnings.size(), 1u);
    EXPECT_EQ(bunny.warnings[0].loc.line, 2);
    EXPECT_NE(bunny.warnings[0].message.find("not closed"), std::string::npos);
    EXPECT_NE(errorOf("mesh(\"no/such.ply\");").find("no/such.ply"), std::string::npos);
    EXPECT_NE(errorOf("volume(\"no/such.vdb\");").find("no/such.vdb"), std::string::npos);
}

TEST(Csg, PolyhedronSignIgnoresFaceOrientationAndSelfIntersection) {
    // A cube with its faces listed in mixed orientations.
    std::vector<glm::vec3> p{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    std::vector<std::vector<int>> faces{{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                        {2, 3, 7, 6}, {1, 2, 6, 5}, {0, 4, 7, 3}};
    auto good = csg::makePolyhedron(p, faces);
    std::reverse(faces[1].begin(), faces[1].end());
    std::reverse(faces[4].begin(), faces[4].end());
    auto mixed = csg::makePolyhedron(p, faces);
    for (int i = 0; i <= 20; ++i)
        for (int j = 0; j <= 8; ++j) {
            const float x = -0.55f + 0.1f * float(i), y = -0.45f + 0.25f * float(j);
            const glm::vec3 q(x, y, 0.3f);
            EXPECT_NEAR(good->value(q), mixed->value(q), 1e-6f) << x << " " << y;
            EXPECT_EQ(good->value(q) < 0, x > 0 && x < 1 && y > 0 && y < 1) << x << " " << y;
        }
    // Two overlapping cubes as one triangle soup (self-intersecting): the union's inside.
    std::vector<glm::vec3> pts;
    std::vector<glm::uvec3> tris;
    for (float off : {0.f, 0.5f}) {
        const auto base = static_cast<unsigned>(pts.size());
        for (const auto& q : p) pts.push_back(q + glm::vec3(off, 0, 0));
        for (const auto& f : std::vector<std::vector<int>>{
                 {0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {2, 3, 7, 6}, {1, 2, 6, 5}, {0, 4, 7, 3}}) {
            tris.emplace_back(base + f[0], base + f[1], base + f[2]);
            tris.emplace_back(base + f[0], base + f[2], base + f[3]);
        }
    }
    auto soup = csg::makeTriangleMeshField(pts, tris);
    EXPECT_LT(soup->value(glm::vec3(0.75f, 0.5f, 0.5f)), 0.f);  // inside both
    EXPECT_LT(soup->value(glm::vec3(0.25f, 0.5f, 0.5f)), 0.f);
    EXPECT_LT(soup->value(glm::vec3(1.25f, 0.5f, 0.5f)), 0.f);
    EXPECT_GT(soup->value(glm::vec3(1.75f, 0.5f, 0.5f)), 0.f);
    EXPECT_NEAR(soup->value(glm::vec3(0.75f, 0.5f, 0.9f)), -0.1f, 1e-5f);  // distance to the nearest face
}

TEST(Csg, MeshFieldBatchSignsMatchPointSigns) {
    // Batches take the sign of an earlier point whose surface-free ball holds them; that must agree with
    // the winding number computed point by point, on 8^3 blocks along the cow's surface (its head
    // self-intersects) at two voxel sizes.
    mesh::TriMesh cow = mesh::readMesh(test::sourceDir() / "data/cow.obj");
    auto f = csg::makeTriangleMeshField(cow.positions, cow.triangles);
    std::size_t compared = 0, insideCount = 0;
    for (float h : {0.004f, 0.02f})
        for (std::size_t v = 0; v < cow.positions.size(); v += 97) {
            std::vector<glm::vec3> block;
            const glm::vec3 corner = glm::floor(cow.positions[v] / (8.f * h)) * (8.f * h);
            for (int x = 0; x < 8; ++x)
                for (int y = 0; y < 8; ++y)
                    for (int z = 0; z < 8; ++z) block.push_back(corner + h * glm::vec3(x, y, z));
            std::vector<float> batch(block.size());
            f->values(block, batch);
            for (std::size_t i = 0; i < block.size(); ++i) {
                ASSERT_EQ(batch[i], f->value(block[i])) << "vertex " << v << " point " << i;
                insideCount += batch[i] < 0;
            }
            compared += block.size();
            // In any order (the batch is cut in boxes by coordinates, not by position in it).
            std::reverse(block.begin(), block.end());
            std::rotate(block.begin(), block.begin() + 37, block.end());
            f->values(block, batch);
            for (std::size_t i = 0; i < block.size(); ++i)
                ASSERT_EQ(batch[i], f->value(block[i])) << "vertex " << v << " shuffled point " << i;
        }
    EXPECT_GT(insideCount, compared / 10);  // the blocks straddle the surface
}

TEST(Csg, BatchValuesOfNestedTransformsMatchPointValues) {
    // Regression: nested transforms shared one scratch buffer, so a boolean's second child under a
    // transform read points its first child had already moved (the showcase's tower came out blocky).
    auto inner =
        csg::makeDifference({implicit::makeTranslated(implicit::makeSphere(1.f), glm::vec3(0, 0, 2)),
                             implicit::makeTransformed(implicit::makeBox(glm::vec3(1.f)),
                                                       glm::mat4(glm::vec4(0.5f, 0, 0, 0), glm::vec4(0, 0.5f, 0, 0),
                                                                 glm::vec4(0, 0, 1, 0), glm::vec4(0.3f, 0, 2, 1)))});
    auto f = implicit::makeTranslated(inner, glm::vec3(4.4f, 2.2f, 0.4f));
    std::vector<glm::vec3> p;
    for (int i = 0; i < 300; ++i) p.emplace_back(4.4f + 0.01f * i - 1.5f, 2.2f + 0.003f * i, 2.4f - 0.005f * i);
    std::vector<float> batch(p.size());
    f->values(p, batch);
    for (std::size_t i = 0; i < p.size(); ++i) EXPECT_FLOAT_EQ(batch[i], f->value(p[i])) << i;
}

TEST(OpenScad, DegenerateObjectsAreIgnoredWithAWarningAndTheRestIsKept) {
    // OpenSCAD renders the rest of a file whose objects have zero, negative or non-finite sizes.
    const std::string degenerate[] = {
        "cube(0);",
        "cube([1, 0, 1]);",
        "cube(size = [inf, 1, 1]);",
        "cube(size = [nan, 1, 1]);",
        "sphere(r = 0);",
        "sphere(r = -1);",
        "cylinder(h = 1, r = 0);",
        "cylinder(h = 0, r = 1);",
        "cylinder(h = 1, r1 = -1, r2 = 1);",
        "linear_extrude(height = 0) square(1);",
        "linear_extrude(height = -1) square(1);",
        "rotate_extrude(angle = 0) translate([2, 0]) square(1);",
        "rotate_extrude() translate([-0.5, 0]) square(1);",
        "polyhedron(points = [[0, 0, 0], [1, 0, 0], [0, 1, 0]], faces = [[0, 1, 2]]);",
        "scale([0, 1, 1]) cube(1);",
        "multmatrix([[0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) cube(1);",
        "linear_extrude(height = 1) sphere(1);",
        "linear_extrude(height = 1) circle(0);",
        "linear_extrude(height = 1) polygon([[0, 0], [1, 0]]);",
    };
    for (const std::string& d : degenerate) {
        const std::string text = d + "\ntranslate([5, 0, 0]) cube(1);\n";
        const auto scene = csg::parseScene(text, "s.isf");
        ASSERT_FALSE(scene.warnings.empty()) << d;
        EXPECT_EQ(scene.warnings[0].loc.line, 1) << d;
        const implicit::Box3 b = scene.root->bounds();
        EXPECT_NEAR(b.min.x, 5.f, 1e-4f) << d;  // only the good cube is left
        EXPECT_NEAR(b.max.x, 6.f, 1e-4f) << d;
    }
    EXPECT_NE(warningsOf("sphere(r = -1);").find("s.isf:1:1: sphere() with a zero, negative or non-finite radius"),
              std::string::npos);
    EXPECT_NE(warningsOf("union() { cube(1); square(2); }").find("ignoring the 2D object square()"), std::string::npos);
    EXPECT_NE(warningsOf("rotate_extrude() translate([-0.5, 0]) square(1);").find("same X coordinate sign"),
              std::string::npos);
}

TEST(OpenScad, FacetedPrimitivesAreOpenScadsPolyhedra) {
    // $fn > 0: OpenSCAD's facets, whose volumes are known exactly. A prism on a regular n-gon of
    // circumradius r: n r^2 sin(2 pi / n) / 2 per unit height.
    auto ngon = [](double r, int n) { return 0.5 * n * r * r * std::sin(2 * M_PI / n); };
    EXPECT_NEAR(meshVolume("cylinder(h = 2, r = 1, $fn = 6);", 0.02f), 2 * ngon(1, 6), 0.01 * 2 * ngon(1, 6));
    EXPECT_NEAR(meshVolume("cylinder(h = 2, r = 1, $fn = 2);", 0.02f), 2 * ngon(1, 3), 0.01 * 2 * ngon(1, 3));
    // A pyramid and a frustum on squares: h (A1 + A2 + sqrt(A1 A2)) / 3.
    const double a1 = ngon(1, 4), a2 = ngon(0.5, 4);
    EXPECT_NEAR(meshVolume("cylinder(h = 3, r1 = 1, r2 = 0, $fn = 4);", 0.02f), a1, 0.01 * a1);
    EXPECT_NEAR(meshVolume("cylinder(h = 3, r1 = 1, r2 = 0.5, $fn = 4);", 0.02f), (a1 + a2 + std::sqrt(a1 * a2)),
                0.01 * (a1 + a2 + std::sqrt(a1 * a2)));
    // The octahedron-like sphere of $fn = 4 (2 rings at 45 and 135 degrees): a square prism of
    // half-height cos 45 between two square caps, plus nothing else: 2 cos45 * 2 sin^2 45.
    const double s45 = std::sqrt(0.5);
    EXPECT_NEAR(meshVolume("sphere(r = 1, $fn = 4);", 0.01f), 2 * s45 * 2 * s45 * s45, 0.01);
    // rotate_extrude with $fn: a square ring of 4 segments is a square frame: (3^2 - 2^2) * 2 per unit height,
    // in diagonal-vertex form (circumradius 3 and 2): 2 r^2 each.
    EXPECT_NEAR(meshVolume("rotate_extrude($fn = 4) translate([2, 0]) square(1);", 0.02f), 2 * 9 - 2 * 4, 0.1);
    // A partial revolve: $fn = 8 over 100 degrees has floor(8 * 100 / 360) = 2 segments of 50 degrees.
    const double seg = 0.5 * (9 - 4) * std::sin(50 * M_PI / 180);
    EXPECT_NEAR(meshVolume("rotate_extrude(angle = 100, $fn = 8) translate([2, 0]) square(1);", 0.02f), 2 * seg,
                0.02 * 2 * seg);
    // A profile on the -x side is taken mirrored; angles beyond a turn are one turn.
    EXPECT_NEAR(meshVolume("rotate_extrude($fn = 4) translate([-3, 0]) square(1);", 0.02f), 10, 0.1);
    EXPECT_NEAR(meshVolume("rotate_extrude(angle = 400, $fn = 4) translate([2, 0]) square(1);", 0.02f), 10, 0.1);
    // The analytic faceted sphere agrees with OpenSCAD's vertices: they lie on its surface.
    const auto s = csg::parseScene("sphere(r = 2, $fn = 10);", "s.isf");
    for (int i = 0; i < 5; ++i) {
        const double phi = M_PI * (i + 0.5) / 5;
        for (int j = 0; j < 10; ++j) {
            const double a = 2 * M_PI * j / 10;
            const glm::vec3 v(2 * std::sin(phi) * std::cos(a), 2 * std::sin(phi) * std::sin(a), 2 * std::cos(phi));
            EXPECT_NEAR(s.root->value(v), 0.f, 1e-5f) << i << " " << j;
        }
    }
}

TEST(OpenScad, PolyhedraWithConcaveFacesTouchingSolidsAndEitherOrientation) {
    // A prism on a concave hexagon (an L-shape): area 3, height 1; the faces are given clockwise seen
    // from outside (OpenSCAD's convention), and the big faces are concave.
    const std::string prism = R"(polyhedron(points = [[0,0,0],[2,0,0],[2,1,0],[1,1,0],[1,2,0],[0,2,0],
        [0,0,1],[2,0,1],[2,1,1],[1,1,1],[1,2,1],[0,2,1]],
        faces = [[0,1,2,3,4,5],[11,10,9,8,7,6],[0,6,7,1],[1,7,8,2],[2,8,9,3],[3,9,10,4],[4,10,11,5],[5,11,6,0]]);)";
    const auto scene = csg::parseScene(prism, "p.isf");
    const implicit::Box3 b = scene.root->bounds();
    EXPECT_EQ(b.max, glm::vec3(2, 2, 1));
    EXPECT_GT(scene.root->value(glm::vec3(1.5f, 1.5f, 0.5f)), 0.f);  // the notch is outside
    EXPECT_LT(scene.root->value(glm::vec3(0.5f, 1.5f, 0.5f)), 0.f);
    EXPECT_NEAR(meshVolume(prism, 0.02f), 3.0, 0.01);
    // Two cubes as one polyhedron, touching along an edge (the mesh is not edge-manifold there).
    std::string two = "polyhedron(points = [";
    for (int c = 0; c < 2; ++c)
        for (int k = 0; k < 8; ++k)
            two += "[" + std::to_string((k & 1) + c) + "," + std::to_string(((k >> 1) & 1) + c) + "," +
                   std::to_string((k >> 2) & 1) + "],";
    two.pop_back();
    two += "], faces = [";
    const int quad[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (int c = 0; c < 2; ++c)
        for (const auto& q : quad)
            two += "[" + std::to_string(q[0] + 8 * c) + "," + std::to_string(q[1] + 8 * c) + "," +
                   std::to_string(q[2] + 8 * c) + "," + std::to_string(q[3] + 8 * c) + "],";
    two.pop_back();
    two += "]);";
    EXPECT_NEAR(meshVolume(two, 0.02f), 2.0, 0.01);
    // OpenSCAD's issue 1198: non-planar quads and pentagons with a point on their own edge. Its volume
    // by OpenSCAD's STL is 2.269375; through pseudonormals the mesh came out open (241 boundary edges).
    const std::string issue1198 = R"(polyhedron(points = [[6.46538, 45.0434, -0.5185], [7.45793, 45.0119, -0.636215],
        [7.45793, 45.9778, -0.895034], [6.46538, 46.0094, -0.77732], [6.46538, 45.5264, -0.64791],
        [6.18882, 44.4605, -2.69418], [7.18137, 44.4289, -2.8119], [7.18137, 45.3948, -3.07072],
        [6.18882, 45.4264, -2.953], [6.18882, 44.9434, -2.82359]],
        faces = [[0, 1, 6, 5], [1, 2, 7, 6], [2, 3, 8, 7], [3, 4, 9, 8], [4, 0, 5, 9], [4, 3, 2, 1, 0], [5, 6, 7, 8, 9]]);)";
    EXPECT_NEAR(meshVolume(issue1198, 0.01f), 2.269375, 0.005 * 2.269375);  // meshVolume checks it is closed
    // Slightly non-planar quads (a twisted box top) are triangulated, not lost.
    EXPECT_NEAR(meshVolume("polyhedron(points = [[0,0,0],[1,0,0],[1,1,0],[0,1,0],[0,0,1],[1,0,1.01],[1,1,1],[0,1,1]],"
                           " faces = [[0,1,2,3],[4,7,6,5],[0,4,5,1],[1,5,6,2],[2,6,7,3],[3,7,4,0]]);",
                           0.01f),
                1.0, 0.01);
}

TEST(OpenScad, FlippedAndOpenPolyhedraAsOpenScadTakesThem) {
    // OpenSCAD's polyhedron-tests: an octahedron of volume 4/3 with its faces all flipped is still a
    // solid; with one face flipped it stands alone as a solid, but inside a boolean operation OpenSCAD's
    // CGAL conversion fails ("The given mesh is not closed!") and skips it.
    const std::string points = "points = [[1,0,0],[-1,0,0],[0,1,0],[0,-1,0],[0,0,1],[0,0,-1]]";
    const std::string allFlipped =
        "polyhedron(" + points + ", faces = [[0,2,4],[0,5,2],[0,4,3],[0,3,5],[1,4,2],[1,2,5],[1,3,4],[1,5,3]]);";
    const std::string oneFlipped =
        "polyhedron(" + points + ", faces = [[0,4,2],[0,2,5],[0,3,4],[0,5,3],[1,2,4],[1,5,2],[1,3,4],[1,3,5]]);";
    EXPECT_NEAR(meshVolume(allFlipped, 0.01f), 4.0 / 3.0, 0.01);
    // Alone, the flipped face is capped back into place: the octahedron, closed.
    EXPECT_NEAR(meshVolume(oneFlipped, 0.01f), 4.0 / 3.0, 0.01);
    const std::string both = "union() { translate([5, 0, 0]) cube(1); " + oneFlipped + " }";
    EXPECT_NEAR(meshVolume(both, 0.01f), 1.0, 0.01);
    EXPECT_NE(warningsOf(both).find("not closed"), std::string::npos) << warningsOf(both);
    EXPECT_EQ(warningsOf(oneFlipped), "");
    // OpenSCAD's issue 964: a polyhedron with a missing face and a face across the others. The generalized
    // winding number of an open mesh crosses 1/2 far from the surface, where the sign flipped with no
    // zero between: the mesh came out open in 155 pieces. Its boundary is capped now: one closed piece.
    const std::string issue964 =
        "polyhedron(points = [[0,0,0],[10,0,0],[10,10,0],[0,10,0],[0,-20,20],[10,-20,20],[10,-20,30],[0,-20,30]],"
        " faces = [[0,1,2,3],[4,5,6,7],[1,2,5,4],[2,3,6,5],[3,0,6,5],[0,1,4,7]]);";
    EXPECT_GT(meshVolume(issue964, 0.25f), 100.0);  // meshVolume checks it is closed
}

TEST(OpenScad, ApexesOnGridSamplesAreKept) {
    // OpenSCAD's example011 (a user's polyhedron) and issue2259 (an extrusion scaled to a point, a generated
    // mesh): the apex lies exactly on a grid sample. Counted outside (a zero), it was cut a voxel short; the
    // field now says "on the surface, inside" with the least negative float. A zero from a difference's
    // negation (-0) stays outside: issue1165's cube minus two cubes 8.8e-11 apart keeps no sheet between them.
    const float voxel = 20.f / 256.f;
    auto topOf = [&](const std::string& text, int components) {
        const mesh::TriMesh m = meshOf(csg::parseScene(text, "apex.csg").root, voxel);
        const auto r = test::expectClosedSurface(m, text);
        EXPECT_EQ(r.components, std::size_t(components)) << text;
        float top = -1e9f;
        for (const glm::vec3& p : m.positions) top = std::max(top, p.z);
        return top;
    };
    EXPECT_GT(topOf("polyhedron(points = [[10,10,0],[10,-10,0],[-10,-10,0],[-10,10,0],[0,0,10]],"
                    " faces = [[0,1,4],[1,2,4],[2,3,4],[3,0,4],[1,0,3],[2,1,3]]);",
                    1),
              10.f - 0.01f * voxel);
    EXPECT_GT(topOf("linear_extrude(height = 10, scale = [0, 0], slices = 2) polygon([[20, 0], [0, 10], [0, -10]]);"
                    "translate([0, 30, 0]) linear_extrude(height = 10, scale = [1, 0], slices = 1)"
                    " polygon([[20, 0], [0, 10], [0, -10]]);",
                    2),
              10.f - 0.01f * voxel);
    const float sheetVoxel = 10.9f / 256.f;
    const mesh::TriMesh m = meshOf(csg::parseScene("difference() { cube(10, center = true);"
                                                   " translate([6, 5.5, 0]) cube(11, center = true);"
                                                   " translate([6, -5.500000000088, 0]) cube(11, center = true); }",
                                                   "issue1165.csg")
                                       .root,
                                   sheetVoxel);
    float right = -1e9f;
    for (const glm::vec3& p : m.positions) right = std::max(right, p.x);
    EXPECT_LT(right, 0.5f + sheetVoxel);
}

TEST(OpenScad, ResizeAutoTakesTheScaleOfTheLargestNewSize) {
    // OpenSCAD's resize-tests (lime and purple rows): with auto, an axis left at 0 takes the scale factor of the
    // largest new size, the first of equals. Volumes of OpenSCAD 2021.01's STLs of the same lines.
    EXPECT_NEAR(meshVolume("resize([5, 0, 20], auto = [false, true, true]) cube(9);", 0.25f), 2000.0, 6.0);
    EXPECT_NEAR(meshVolume("resize([20, 0, 5], auto = [false, true, true]) cube(9);", 0.25f), 2000.0, 6.0);
    EXPECT_NEAR(meshVolume("resize([5, 0, 20], auto = true) cube([1, 2, 3]);", 0.25f), 4000.0 / 3.0, 4.0);
    EXPECT_NEAR(meshVolume("resize([5, 0, 5], auto = true) cube([1, 2, 3]);", 0.05f), 250.0, 0.5);
    EXPECT_NEAR(meshVolume("resize([7, 0, 7], auto = [false, true, true]) cube(1);", 0.05f), 343.0, 0.5);
}

TEST(OpenScad, NonPlanarFacesSplitAlongOpenScadsDiagonals) {
    // OpenSCAD's issue 1061: a twisted stack of non-planar quads. OpenSCAD (libtess2) splits each
    // along its constrained Delaunay diagonal in libtess2's projection; its STL holds 1876.80.
    // Ear clipping alone (fans) gave 2.5% more.
    const std::string issue1061 =
        "polyhedron(points = [[-5, -5, 0], [-5, 5, 0], [5, 5, 0], [5, -5, 0], [-1.87866, -4.21311, 3], "
        "[-4.21311, 5.51058, 3], [5.51058, 7.84504, 3], [7.84504, -1.87866, 3], [1.05099, -3.48892, 6], "
        "[-3.48892, 5.42115, 6], [5.42115, 9.96105, 6], [9.96105, 1.05099, 6], [3.39596, -3.09852, 9], "
        "[-3.09852, 4.50554, 9], [4.50554, 11, 9], [11, 3.39596, 9], [4.91038, -3.17979, 12], "
        "[-3.17979, 2.69807, 12], [2.69807, 10.7882, 12], [10.7882, 4.91038, 12], [5.53441, -3.70439, 15], "
        "[-3.70439, 0.122447, 15], [0.122447, 9.36124, 15], [9.36124, 5.53441, 15], [5.39234, -4.48455, 18], "
        "[-4.48455, -2.9202, 18], [-2.9202, 6.95668, 18], [6.95668, 5.39234, 18]], faces = [[0, 1, 5, 4], "
        "[1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7], [4, 5, 9, 8], [5, 6, 10, 9], [6, 7, 11, 10], [7, 4, 8, 11], "
        "[8, 9, 13, 12], [9, 10, 14, 13], [10, 11, 15, 14], [11, 8, 12, 15], [12, 13, 17, 16], [13, 14, 18, 17], "
        "[14, 15, 19, 18], [15, 12, 16, 19], [16, 17, 21, 20], [17, 18, 22, 21], [18, 19, 23, 22], "
        "[19, 16, 20, 23], [20, 21, 25, 24], [21, 22, 26, 25], [22, 23, 27, 26], [23, 20, 24, 27], "
        "[3, 2, 1, 0], [24, 25, 26, 27]]);";
    EXPECT_NEAR(meshVolume(issue1061, 0.1f), 1876.80, 0.003 * 1876.80);
}
