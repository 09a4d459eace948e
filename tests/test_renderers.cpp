// The renderers: silhouettes against analytic shapes, the Embree and ray-marching paths against
// each other, grids, translucency, degenerate inputs, determinism and golden images.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <embree3/rtcore.h>
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <openvdb/tools/Composite.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/LevelSetSphere.h>
#include "csg/nodes.h"
#include "csg/scene.h"
#include "implicit/primitives.h"
#include "implicit/tape.h"
#include "mesh/io.h"
#include "render/embree_renderer.h"
#include "render/grid_march.h"
#include "render/image.h"
#include "render/ray_march.h"
#include "render/shading.h"
#include "test_util.h"
#include "volume/marching_cubes.h"
#include "volume/sample.h"
#include "volume/vdb_io.h"

using namespace isoforge;

namespace {

struct Init {
    Init() { volume::initializeOpenVdb(); }
} init;

render::RenderOptions small(int w = 240, int h = 180) {
    render::RenderOptions o;
    o.width = w;
    o.height = h;
    return o;
}

double iou(const render::Frame& a, const render::Frame& b) {
    const auto sa = render::silhouette(a), sb = render::silhouette(b);
    std::size_t both = 0, any = 0;
    for (std::size_t i = 0; i < sa.size(); ++i) {
        both += sa[i] && sb[i];
        any += sa[i] || sb[i];
    }
    return any ? double(both) / double(any) : 1.0;
}

/// Mean absolute colour difference (linear, per channel) over pixels both frames cover fully.
double meanColourDifference(const render::Frame& a, const render::Frame& b) {
    double sum = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.pixels(); ++i)
        if (a.color[i].a >= 1.f && b.color[i].a >= 1.f) {
            for (int k = 0; k < 3; ++k) sum += std::abs(a.color[i][k] - b.color[i][k]);
            n += 3;
        }
    return n ? sum / double(n) : 0.0;
}

/// The field sampled and meshed (as `isoforge render --method mesh` does), one object.
mesh::TriMesh meshOf(const implicit::FieldPtr& f, float voxel) {
    volume::SampleOptions so;
    so.voxelSize = voxel;
    volume::MeshingOptions mo;
    mo.normals = true;
    return volume::extractIsosurface(*volume::sample(f, so), mo);
}

/// The field meshed and split into one object per material, as the CLI does, through Embree.
render::Frame castByMaterial(const implicit::FieldPtr& field, float voxel, const render::Look& look,
                             const render::RenderOptions& o) {
    std::vector<implicit::Material> mats;
    const std::vector<mesh::TriMesh> parts = render::splitByMaterial(meshOf(field, voxel), *field, mats);
    std::vector<render::MeshObject> objs;
    for (std::size_t k = 0; k < parts.size(); ++k) objs.push_back({&parts[k], mats[k], false});
    return render::renderMeshes(objs, look, o);
}

render::Look orthoLook(const implicit::Box3& box, float aspect) {
    render::Look look;
    look.camera = render::frameBox(box, aspect, glm::vec3(0, 1, 0));
    look.camera.orthographic = true;
    return look;
}

}  // namespace

TEST(Renderers, SphereSilhouetteIsTheAnalyticDisc) {
    // Orthographic view of a unit sphere: covered pixels are those whose centre lies in the disc.
    const auto sphere = implicit::makeSphere(1.f);
    const implicit::Box3 box{glm::vec3(-1.f), glm::vec3(1.f)};
    auto o = small(200, 200);
    const render::Look look = orthoLook(box, 1.f);
    const render::Frame marched = render::marchField(sphere, box.expanded(0.1f), look, o);
    const mesh::TriMesh m = meshOf(sphere, 0.01f);
    const render::Frame cast = render::renderMeshes({{&m, {}, false}}, look, o);
    render::Frame disc = marched;
    const float halfHeight = 0.5f * look.camera.orthoHeight;
    for (int y = 0; y < o.height; ++y)
        for (int x = 0; x < o.width; ++x) {
            const float u = ((x + 0.5f) / o.width * 2.f - 1.f) * halfHeight,
                        v = ((y + 0.5f) / o.height * 2.f - 1.f) * halfHeight;
            disc.color[static_cast<std::size_t>(y * o.width + x)].a = u * u + v * v < 1.f ? 1.f : 0.f;
        }
    EXPECT_GE(iou(marched, disc), 0.995);
    EXPECT_GE(iou(cast, disc), 0.995);
}

TEST(Renderers, EmbreeAndRayMarchingAgreeOnACsgScene) {
    // A coloured CSG scene, perspective, shadows from two lights: silhouettes and shading agree.
    const csg::Scene s = csg::parseScene(R"(
        color("steelblue") difference() { cube(2, center = true); sphere(1.3); }
        translate([2.5, 0, 0]) color("gold") torus(R = 0.8, r = 0.3);
        translate([0, 0, -1.3]) color("white") box(size = [7, 4, 0.4]);
    )",
                                         "agree.isf");
    const implicit::Box3 box = s.root->bounds();
    auto o = small(320, 240);
    render::Look look;
    look.camera = render::frameBox(box, 320.f / 240.f);
    const render::Frame marched = render::marchField(s.root, box.expanded(0.05f), look, o);
    const render::Frame cast = castByMaterial(s.root, 0.005f, look, o);
    const double overlap = iou(marched, cast), diff = meanColourDifference(marched, cast);
    EXPECT_GE(overlap, 0.995);
    // Measured 0.004-0.006: normals from the field's gradient vs interpolated mesh normals, and
    // shadow edges a voxel apart. 0.02 is about 5 levels of 8-bit sRGB in mid-grey.
    EXPECT_LT(diff, 0.02) << "IoU " << overlap;
}

namespace {
/// A field with its gradient bound hidden: the marcher bisects it by intervals instead of sphere
/// tracing it (the path tapes without a bound take).
class WithoutBound final : public implicit::Field {
public:
    explicit WithoutBound(implicit::FieldPtr f) : f_(std::move(f)) {}
    static implicit::FieldPtr wrap(implicit::FieldPtr f) { return f ? std::make_shared<WithoutBound>(f) : nullptr; }
    float value(const glm::vec3& p) const override { return f_->value(p); }
    implicit::Interval bound(const implicit::Box3& b) const override { return f_->bound(b); }
    implicit::Box3 bounds() const override { return f_->bounds(); }
    bool isDistance() const override { return false; }
    float gradientBound() const override { return std::numeric_limits<float>::infinity(); }
    implicit::FieldPtr simplify(const implicit::Box3& b) const override { return wrap(f_->simplify(b)); }
    implicit::Pruned prune(const implicit::Box3& b) const override {
        implicit::Pruned p = f_->prune(b);
        return {wrap(p.field), p.bound};
    }
    std::string describe() const override { return "without bound: " + f_->describe(); }

private:
    implicit::FieldPtr f_;
};
}  // namespace

TEST(Renderers, TapesWithAGradientBoundAreSphereTracedToTheSameImage) {
    // A union of 60 balls on a spiral as a tape (sqrt of squares minus radii, min-combined: the
    // structure gives the bound 1): sphere traced, it shows what interval bisection and the mesh
    // path show.
    std::string e = "sqrt((x - 0.7)^2 + y^2 + (z + 0.8)^2) - 0.11";
    for (int i = 1; i < 60; ++i) {
        const double t = i / 60.0;
        e = "min(" + e + ", sqrt((x - " + std::to_string(0.7 * (1 - t) * std::cos(12 * t)) + ")^2 + (y - " +
            std::to_string(0.7 * (1 - t) * std::sin(12 * t)) + ")^2 + (z - " + std::to_string(1.6 * t - 0.8) +
            ")^2) - " + std::to_string(0.05 + 0.06 * (1 - t)) + ")";
    }
    const auto tape =
        implicit::makeTapeField(implicit::parseExpression(e), implicit::Box3{glm::vec3(-1.f), glm::vec3(1.f)}, "balls");
    ASSERT_NEAR(tape->gradientBound(), 1.f, 1e-5f);
    const implicit::Box3 box{glm::vec3(-1.f), glm::vec3(1.f)};
    auto o = small(320, 240);
    render::Look look;
    look.camera = render::frameBox(box, 320.f / 240.f);
    const render::Frame traced = render::marchField(tape, box, look, o);
    const render::Frame bisected = render::marchField(WithoutBound::wrap(tape), box, look, o);
    const render::Frame cast = castByMaterial(tape, 0.004f, look, o);
    EXPECT_GE(iou(traced, bisected), 0.999);  // measured: 1 and 1.4e-5
    EXPECT_LT(meanColourDifference(traced, bisected), 0.002);
    EXPECT_GE(iou(traced, cast), 0.99);
    EXPECT_LT(meanColourDifference(traced, cast), 0.02);
}

TEST(Renderers, TranslucentObjectsCastNoShadowOnEitherPath) {
    // A glass sphere over a white slab, lit from the side so that its shadow, if it cast one, would
    // fall on the slab in view. Translucent layers let light through on both paths.
    const csg::Scene s = csg::parseScene(R"(
        color("white") box(size = [8, 6, 0.4], center = true);
        translate([1, 0, 1.6]) color([0.5, 0.8, 0.95, 0.4]) sphere(1);
    )",
                                         "glass.isf");
    const implicit::Box3 box = s.root->bounds();
    auto o = small(320, 240);
    render::Look look;
    look.camera = render::frameBox(box, 320.f / 240.f, glm::vec3(-0.3f, 1.f, -0.8f));
    look.lights.push_back({false, glm::vec3(-1.f, 0.4f, -0.8f), glm::vec3(1.f), 1.f});
    const render::Frame marched = render::marchField(s.root, box, look, o);
    const render::Frame cast = castByMaterial(s.root, 0.01f, look, o);
    // The slab lit where the sphere's shadow would be: compare every pixel, counting those that
    // differ by more than 0.1 in some channel (a shadow darkens the white slab by ~0.5).
    std::size_t differ = 0, covered = 0;
    for (std::size_t i = 0; i < marched.pixels(); ++i) {
        if (marched.color[i].a < 1.f || cast.color[i].a < 1.f) continue;
        ++covered;
        const glm::vec4 d = glm::abs(marched.color[i] - cast.color[i]);
        differ += std::max({d.r, d.g, d.b}) > 0.1f;
    }
    ASSERT_GT(covered, marched.pixels() / 8);
    // Measured 61 of 15,334 (0.4%): single pixels along the slab's sharp edges, where the mesh's
    // vertex normals are averaged across the edge. When the march path cast the sphere's shadow:
    // 1,954 (12.8%).
    EXPECT_LT(double(differ), 0.01 * double(covered)) << differ << " of " << covered << " pixels differ";
    EXPECT_GE(iou(marched, cast), 0.995);
}

/// The field as it is, never simplified: the reference for the marcher's per-tile pruning.
class Unpruned final : public implicit::Field {
public:
    explicit Unpruned(implicit::FieldPtr f) : f_(std::move(f)) {}
    float value(const glm::vec3& p) const override { return f_->value(p); }
    implicit::Interval bound(const implicit::Box3& b) const override { return f_->bound(b); }
    implicit::Box3 bounds() const override { return f_->bounds(); }
    glm::vec3 gradient(const glm::vec3& p) const override { return f_->gradient(p); }
    bool isDistance() const override { return f_->isDistance(); }
    std::string describe() const override { return f_->describe(); }
    const implicit::Material* materialAt(const glm::vec3& p) const override { return f_->materialAt(p); }
    bool hasMaterial() const override { return f_->hasMaterial(); }

private:
    implicit::FieldPtr f_;
};

TEST(Renderers, MarchedShadowsAreThoseOfTheWholeField) {
    // Shadow and ambient-occlusion rays march the field simplified to each cell of the grid they walk
    // (render/field_grid.h), and skip cells where every surface is translucent. A cell that dropped a
    // caster would lose shadows: compare with the field never simplified (whose cells all hold the
    // whole field, glass included, so its shadow rays find the glass and pass it by its material),
    // under a directional and a point light, with and without ambient occlusion. The blobby makes the
    // field non-distance (interval subdivision).
    const csg::Scene s = csg::parseScene(R"(
        color("white") box(size = [10, 8, 0.4], center = true);
        translate([-2, 1, 1.2]) color("steelblue") cube(1.6, center = true);
        translate([2, -1, 0.3]) color("gold") blobby(threshold = 0.5) {
            ball(center = [0, 0, 0.8], r = 1.6);
            ball(center = [0.6, 0.2, 1.4], r = 1.3);
        }
        translate([0, -2.5, 1.5]) color([0.5, 0.8, 0.95, 0.5]) sphere(0.8);
    )",
                                         "shadows.isf");
    const implicit::Box3 box = s.root->bounds();
    // Looking straight down, a tile's own box is a thin column: the casters of the long shadows that
    // the low lights throw across the floor are in other tiles' columns, reached only by the sweep.
    render::Look look;
    look.camera = render::frameBox(box, 4.f / 3.f, glm::vec3(0.f, 0.f, -1.f));
    look.camera.up = glm::vec3(0.f, 1.f, 0.f);
    look.lights.push_back({false, glm::vec3(1.f, 0.3f, -0.45f), glm::vec3(1.f), 0.8f});
    look.lights.push_back({true, glm::vec3(-4.5f, -3.5f, 2.f), glm::vec3(1.f), 0.6f});
    const auto whole = std::make_shared<Unpruned>(s.root);
    for (const int ao : {0, 4}) {
        auto o = small(160, 120);
        o.aoSamples = ao;
        const render::Frame pruned = render::marchField(s.root, box, look, o);
        const render::Frame reference = render::marchField(whole, box, look, o);
        std::size_t differ = 0;
        for (std::size_t i = 0; i < pruned.pixels(); ++i) {
            const glm::vec4 d = glm::abs(pruned.color[i] - reference.color[i]);
            differ += std::max({d.r, d.g, d.b, d.a}) > 0.01f;
        }
        EXPECT_EQ(differ, 0u) << "ambient-occlusion rays " << ao;
        // The shadows are there to be dropped: without shadow rays, many pixels are brighter.
        o.shadows = false;
        const render::Frame unshadowed = render::marchField(s.root, box, look, o);
        std::size_t shadowed = 0;
        for (std::size_t i = 0; i < pruned.pixels(); ++i) shadowed += unshadowed.color[i].r - pruned.color[i].r > 0.05f;
        EXPECT_GT(shadowed, pruned.pixels() / 20) << "ambient-occlusion rays " << ao;
    }
}

TEST(Renderers, RayMarchingFindsSurfacesLyingOnTheirBounds) {
    // A rounded slab's faces are its bounds, and the CLI passes the bounds as the region: rays that
    // started exactly there could start inside (by rounding) and find the slab's far side instead.
    const csg::Scene s = csg::parseScene("box(size = [16, 11, 0.8], r = 0.25, center = true);", "slab.isf");
    const implicit::Box3 box = s.root->bounds();
    auto o = small(320, 240);
    o.depth = true;
    render::Look look;
    look.camera.eye = glm::vec3(11, -13, 8.5);
    look.camera.target = glm::vec3(0, 0, 1.2);
    look.camera.fov = 34.f;
    const render::Frame exact = render::marchField(s.root, box, look, o);
    const render::Frame roomy = render::marchField(s.root, box.expanded(1.f), look, o);
    std::size_t hits = 0, wrong = 0;
    for (std::size_t i = 0; i < exact.pixels(); ++i) {
        hits += std::isfinite(roomy.depth[i]);
        wrong += std::isfinite(roomy.depth[i]) != std::isfinite(exact.depth[i]) ||
                 (std::isfinite(roomy.depth[i]) && std::abs(exact.depth[i] - roomy.depth[i]) > 1e-3f);
    }
    ASSERT_GT(hits, exact.pixels() / 4);
    EXPECT_EQ(wrong, 0u) << "of " << hits << " pixels that see the slab";
}

TEST(Renderers, GridMarcherMatchesTheAnalyticSphereAndTheFieldPath) {
    // data/sphere.vdb: a level-set sphere of radius 3.
    const auto grid = volume::readFloatGrid(test::sourceDir() / "data/sphere.vdb");
    const implicit::Box3 box{glm::vec3(-3.f), glm::vec3(3.f)};
    auto o = small(200, 200);
    const render::Look look = orthoLook(box, 1.f);
    render::RenderStats st;
    const render::Frame g = render::marchGrid(*grid, {render::IsoLayer{}}, true, look, o, &st);
    const render::Frame f = render::marchField(implicit::makeSphere(3.f), box.expanded(0.1f), look, o);
    EXPECT_GE(iou(g, f), 0.995);
    EXPECT_LT(meanColourDifference(g, f), 0.02);
    EXPECT_TRUE(st.warnings.empty());
}

TEST(Renderers, TranslucentLayersShowWhatIsBehind) {
    // A translucent shell around an opaque red core: the centre pixel mixes both colours.
    const auto grid = volume::readFloatGrid(test::sourceDir() / "data/sphere.vdb");
    const implicit::Box3 box{glm::vec3(-3.f), glm::vec3(3.f)};
    auto o = small(101, 101);
    const render::Look look = orthoLook(box, 1.f);
    render::IsoLayer skin, core;
    skin.iso = 0.f;
    skin.material.color = glm::vec4(0.2f, 0.4f, 1.f, 0.3f);
    core.iso = -0.12f;  // 2.4 voxels inside
    core.material.color = glm::vec4(1.f, 0.f, 0.f, 1.f);
    const render::Frame both = render::marchGrid(*grid, {skin, core}, true, look, o);
    const render::Frame skinOnly = render::marchGrid(*grid, {skin}, true, look, o);
    const glm::vec4 c = both.color[50 * 101 + 50], s = skinOnly.color[50 * 101 + 50];
    EXPECT_GT(c.r, s.r + 0.05f) << "the red core shows through the skin";
    EXPECT_GT(c.b, 0.02f);
}

TEST(Renderers, DegenerateInputsGiveAnImageAndAWarning) {
    auto o = small(64, 48);
    render::Look look;
    look.camera = render::frameBox({glm::vec3(-1.f), glm::vec3(1.f)}, 64.f / 48.f);
    render::RenderStats st;
    // An empty scene.
    const render::Frame e = render::marchField(csg::makeEmpty(), implicit::Box3{}, look, o, &st);
    EXPECT_EQ(e.pixels(), 64u * 48u);
    EXPECT_FALSE(st.warnings.empty());
    // No triangles.
    st = {};
    const mesh::TriMesh none;
    render::renderMeshes({{&none, {}, false}}, look, o, &st);
    EXPECT_FALSE(st.warnings.empty());
    // A grid without active values.
    st = {};
    const auto empty = openvdb::FloatGrid::create(1.f);
    render::marchGrid(*empty, {render::IsoLayer{}}, true, look, o, &st);
    EXPECT_FALSE(st.warnings.empty());
    // A grid seen from a trillion units away: background, no undefined index arithmetic (UBSan in CI).
    {
        const auto sphere = volume::readFloatGrid(test::sourceDir() / "data/sphere.vdb");
        render::Look far = look;
        far.camera.eye = glm::vec3(1e12f, -3e12f, 2e12f);
        far.camera.target = glm::vec3(0.f);
        const render::Frame f = render::marchGrid(*sphere, {render::IsoLayer{}}, true, far, o);
        EXPECT_EQ(f.pixels(), 64u * 48u);
    }
    // The camera inside a sphere: its inside is drawn, and a warning.
    st = {};
    render::Look inside = look;
    inside.camera.eye = glm::vec3(0.f, 0.f, 0.2f);
    const render::Frame in =
        render::marchField(implicit::makeSphere(1.f), {glm::vec3(-1.1f), glm::vec3(1.1f)}, inside, o, &st);
    EXPECT_FALSE(st.warnings.empty());
    EXPECT_EQ(render::silhouette(in)[24 * 64 + 32], true);
}

TEST(Renderers, SamePixelsWhateverTheThreadCount) {
    const csg::Scene s = csg::parseScene("color(\"tomato\") torus(R = 1, r = 0.4); sphere(0.5);", "t.isf");
    auto o = small(160, 120);
    o.spp = 2;
    o.aoSamples = 2;
    render::Look look;
    look.camera = render::frameBox(s.root->bounds(), 160.f / 120.f);
    const mesh::TriMesh m = meshOf(s.root, 0.02f);
    const auto grid = volume::readFloatGrid(test::sourceDir() / "data/sphere.vdb");
    render::Look gridLook;
    gridLook.camera = render::frameBox({glm::vec3(-3.f), glm::vec3(3.f)}, 160.f / 120.f);
    std::optional<render::Frame> first, firstMesh, firstGrid;
    for (int threads : {1, 2, 4}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        const render::Frame f = render::marchField(s.root, s.root->bounds().expanded(0.05f), look, o);
        const render::Frame g = render::renderMeshes({{&m, {}, false}}, look, o);
        const render::Frame v = render::marchGrid(*grid, {render::IsoLayer{}}, true, gridLook, o);
        if (!first) {
            first = f;
            firstMesh = g;
            firstGrid = v;
            continue;
        }
        EXPECT_EQ(std::memcmp(first->color.data(), f.color.data(), f.color.size() * sizeof(glm::vec4)), 0);
        EXPECT_EQ(std::memcmp(firstMesh->color.data(), g.color.data(), g.color.size() * sizeof(glm::vec4)), 0);
        EXPECT_EQ(std::memcmp(firstGrid->color.data(), v.color.data(), v.color.size() * sizeof(glm::vec4)), 0);
    }
}

TEST(Renderers, GoldenImages) {
    // Small renders of bundled scenes against images in tests/data/golden (made by this renderer at
    // the commit that added them; regenerate with ISOFORGE_UPDATE_GOLDEN=1 after an intended change).
    // Tolerance: mean absolute 8-bit difference below 1.5 levels and under 1% of pixels off by more than 24.
    const auto dir = test::sourceDir() / "tests/data/golden";
    struct Case {
        const char* name;
        const char* scene;
        bool march;
    };
    for (const Case& c :
         {Case{"showcase_mesh", "examples/showcase.isf", false}, Case{"bracket_march", "examples/bracket.isf", true}}) {
        const csg::Scene s = csg::readScene((test::sourceDir() / c.scene).string());
        auto o = small(192, 144);
        render::Look look;
        look.camera = {s.camera.eye, s.camera.target, s.camera.up, s.camera.fov, s.camera.orthographic, 0.f};
        for (const auto& l : s.lights) look.lights.push_back({l.point, l.vector, l.color, l.intensity});
        look.backgroundTop = s.backgroundTop;
        look.backgroundBottom = s.backgroundBottom;
        if (!s.camera.given) look.camera = render::frameBox(s.root->bounds(), 192.f / 144.f);
        render::Frame f;
        if (c.march) {
            f = render::marchField(s.root, s.root->bounds().expanded(0.01f), look, o);
        } else {
            const mesh::TriMesh m = meshOf(s.root, glm::length(s.root->bounds().size()) / 200.f);
            f = render::renderMeshes({{&m, {}, false}}, look, o);
        }
        const auto path = dir / (std::string(c.name) + ".png");
        if (std::getenv("ISOFORGE_UPDATE_GOLDEN")) render::writeImage(path, render::toDisplayImage(f));
        const render::Image ref = render::readImage(path);
        const render::Image now = render::toDisplayImage(f);
        ASSERT_EQ(ref.width, now.width);
        ASSERT_EQ(ref.height, now.height);
        // Compare in 8-bit sRGB, as the files hold.
        auto enc = [](float v) {
            v = std::clamp(v, 0.f, 1.f);
            return 255.f * (v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f);
        };
        double sum = 0;
        std::size_t off = 0;
        for (std::size_t i = 0; i < now.pixels.size(); ++i) {
            const float d = std::abs(enc(now.pixels[i]) - enc(ref.pixels[i]));
            sum += d;
            off += d > 24.f;
        }
        EXPECT_LT(sum / double(now.pixels.size()), 1.5) << c.name;
        EXPECT_LT(double(off) / double(now.pixels.size()), 0.01) << c.name;
    }
}

namespace {

/// The first crossing of any layer along a ray, by brute force: steps of a fifth of a voxel through
/// the grid's active box, then bisection. {-1, -1} when there is none.
std::pair<float, int> bruteFirstHit(const openvdb::FloatGrid& g, const std::vector<render::IsoLayer>& layers,
                                    bool below, const render::detail::Ray& r) {
    const openvdb::CoordBBox ib = g.evalActiveVoxelBoundingBox();
    const openvdb::Vec3d lo = g.indexToWorld(ib.min().asVec3d() - openvdb::Vec3d(1.0)),
                         hi = g.indexToWorld(ib.max().asVec3d() + openvdb::Vec3d(1.0));
    float t0 = 0.f, t1 = 1e30f;
    for (int k = 0; k < 3; ++k) {
        const float a = (float(lo[k]) - r.origin[k]) / r.dir[k], b = (float(hi[k]) - r.origin[k]) / r.dir[k];
        t0 = std::max(t0, std::min(a, b));
        t1 = std::min(t1, std::max(a, b));
    }
    if (t0 > t1) return {-1.f, -1};
    openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> smp(g);
    auto mask = [&](float t) {
        const glm::vec3 p = r.origin + t * r.dir;
        const float v = smp.wsSample(openvdb::Vec3d(p.x, p.y, p.z));
        unsigned m = 0;
        for (std::size_t i = 0; i < layers.size(); ++i)
            if (below ? v < layers[i].iso : v > layers[i].iso) m |= 1u << i;
        return m;
    };
    const float step = 0.2f * float(g.voxelSize()[0]);
    const unsigned m0 = mask(t0);
    for (float t = t0 + step; t <= t1; t += step) {
        const unsigned m = mask(t);
        if (m == m0) continue;
        float a = t - step, b = t;
        for (int k = 0; k < 30; ++k) (mask(0.5f * (a + b)) == m0 ? a : b) = 0.5f * (a + b);
        const unsigned changed = mask(b) ^ m0;
        for (int i = 0; i < 16; ++i)
            if (changed & (1u << i)) return {b, i};
    }
    return {-1.f, -1};
}

}  // namespace

TEST(Renderers, GridPrePassFindsWhatMarchingFromTheEyeFinds) {
    // The depth pre-pass only starts rays late and stops them early: every first hit must be where a
    // brute-force march (fifth-voxel steps, bisection) finds it, and level sets must look as when each
    // ray is marched from the eye through the tree. A level set (Newton steps) in perspective and
    // orthographic views, with one and four samples per pixel; a fog volume with active tiles and two
    // iso-surfaces, the outer one translucent (half-voxel steps, bisection), then both opaque.
    const auto sphere = volume::readFloatGrid(test::sourceDir() / "data/sphere.vdb");
    auto fog = openvdb::FloatGrid::create(0.f);
    fog->setGridClass(openvdb::GRID_FOG_VOLUME);
    fog->setTransform(openvdb::math::Transform::createLinearTransform(0.05));
    {
        auto acc = fog->getAccessor();
        for (int i = -40; i <= 40; ++i)
            for (int j = -40; j <= 40; ++j)
                for (int k = -40; k <= 40; ++k) {
                    const float r = std::sqrt(float(i * i + j * j + k * k)) * 0.05f;
                    if (r < 2.f) acc.setValue(openvdb::Coord(i, j, k), std::clamp(2.f - r, 0.f, 1.f));
                }
        fog->tree().fill(openvdb::CoordBBox(openvdb::Coord(24), openvdb::Coord(55)), 0.8f, true);  // tiles
    }
    render::IsoLayer outer, inner;
    outer.iso = 0.3f;
    outer.material.color = glm::vec4(0.3f, 0.5f, 1.f, 0.4f);
    inner.iso = 0.7f;
    inner.material.color = glm::vec4(1.f, 0.8f, 0.6f, 1.f);
    render::IsoLayer outerOpaque = outer;
    outerOpaque.material.color.a = 1.f;
    struct Case {
        const openvdb::FloatGrid* grid;
        std::vector<render::IsoLayer> layers;
        bool below, ortho;
        int spp;
        implicit::Box3 box;
    };
    const implicit::Box3 unit{glm::vec3(-3.f), glm::vec3(3.f)};
    const implicit::Box3 fogBox{glm::vec3(-2.f), glm::vec3(2.8f)};
    const Case cases[] = {{sphere.get(), {render::IsoLayer{}}, true, false, 1, unit},
                          {sphere.get(), {render::IsoLayer{}}, true, true, 4, unit},
                          {fog.get(), {outer, inner}, false, false, 1, fogBox},
                          {fog.get(), {outer, inner}, false, true, 4, fogBox},
                          {fog.get(), {outerOpaque, inner}, false, false, 1, fogBox},
                          {fog.get(), {outerOpaque, inner}, false, true, 4, fogBox}};
    for (const Case& c : cases) {
        const int w = 160, h = 120;
        auto o = small(w, h);
        o.spp = c.spp;
        o.depth = true;
        o.objectId = true;
        render::Look look;
        look.camera = render::frameBox(c.box, float(w) / float(h), glm::vec3(0.3f, 1.f, 0.2f));
        look.camera.orthographic = c.ortho;
        const bool levelSet = c.grid == sphere.get();
        const std::string what = std::string(levelSet ? "level set" : "fog") +
                                 (c.ortho ? ", orthographic" : ", perspective") + ", spp " + std::to_string(c.spp);
        const render::Frame fast = render::PreparedGrid(*c.grid, c.layers, c.below).render(look, o);
        const float voxel = float(c.grid->voxelSize()[0]);
        // Against brute force, on every fifth pixel (the first sample of a pixel is at its centre).
        const render::detail::RayGenerator gen(look.camera, w, h);
        std::size_t checked = 0, hitsDiffer = 0, depthsDiffer = 0, layersDiffer = 0;
        for (std::size_t i = 0; i < fast.pixels(); i += 5) {
            const auto [bt, bl] =
                bruteFirstHit(*c.grid, c.layers, c.below, gen(float(i % w) + 0.5f, float(i / w) + 0.5f));
            const bool fastHit = std::isfinite(fast.depth[i]);
            ++checked;
            if (fastHit != (bl >= 0)) {
                ++hitsDiffer;
                continue;
            }
            if (!fastHit) continue;
            depthsDiffer += std::abs(fast.depth[i] - bt) > 0.1f * voxel;
            layersDiffer += int(fast.objectId[i]) != bl + 1;
        }
        EXPECT_LE(hitsDiffer, checked / 500) << what << " (silhouette pixels)";
        EXPECT_LE(depthsDiffer, checked / 200) << what;
        EXPECT_LE(layersDiffer, checked / 500) << what;
        if (!levelSet) continue;
        // The tree traversal from the eye, the reference for level sets (on grids with active tiles it
        // is the less accurate of the two: it does not sample the inside of tiles between leaves).
        const render::Frame slow = render::PreparedGrid(*c.grid, c.layers, c.below, false).render(look, o);
        EXPECT_GE(iou(fast, slow), 0.999) << what;
        EXPECT_LT(meanColourDifference(fast, slow), 0.004) << what;
    }
}

TEST(Renderers, GridShadowRaysConfinedFromTheLightFindWhatBruteForceFinds) {
    // Shadow rays of directional lights step only from their start to the nearest crossed-cell box along
    // their light pixel (detail::LightView). Two level-set spheres, the big one casting its shadow on the
    // small one, lit from three directions (one straight down a grid axis): each lit pixel's shadow ray
    // is marched by brute force (tenth-voxel steps from the renderer's start, 0.75 voxel off the surface,
    // through the whole grid), and the renderer must agree. The march through the tree (the pre-pass
    // off) is the less accurate here: it missed rays grazing the big sphere that brute force and the
    // confined march see blocked.
    const float voxel = 0.05f;
    auto grid =
        openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(1.f, openvdb::Vec3f(1.2f, 0.f, 0.f), voxel, 3.f);
    openvdb::tools::csgUnion(*grid, *openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(
                                        0.5f, openvdb::Vec3f(-0.6f, 0.f, 0.3f), voxel, 3.f));
    const implicit::Box3 box{glm::vec3(-1.2f, -1.1f, -1.1f), glm::vec3(2.3f, 1.1f, 1.1f)};
    auto acc = grid->getConstAccessor();
    for (const glm::vec3 shining :
         {glm::vec3(-1.f, 0.f, 0.f), glm::vec3(-1.f, 0.3f, -0.4f), glm::vec3(-0.8f, -0.5f, 0.2f)}) {
        SCOPED_TRACE("light shining along (" + std::to_string(shining.x) + ", " + std::to_string(shining.y) + ", " +
                     std::to_string(shining.z) + ")");
        render::Look look;
        look.camera = render::frameBox(box, 4.f / 3.f, glm::vec3(0.2f, 1.f, -0.3f));
        look.lights = {render::Light{false, shining, glm::vec3(1.f), 1.f}};
        auto o = small(200, 150);
        o.depth = o.normal = true;
        const render::PreparedGrid confined(*grid, {render::IsoLayer{}}, true);
        const render::Frame shadowed = confined.render(look, o);
        o.shadows = false;
        const render::Frame lit = confined.render(look, o);
        const render::detail::RayGenerator gen(look.camera, o.width, o.height);
        const glm::vec3 towards = -glm::normalize(shining);
        std::size_t checked = 0, blocked = 0, disagree = 0;
        for (std::size_t i = 0; i < shadowed.pixels(); ++i) {
            if (!std::isfinite(shadowed.depth[i]) || glm::dot(shadowed.normal[i], towards) < 0.1f) continue;
            const auto ray = gen(float(i % 200) + 0.5f, float(i / 200) + 0.5f);
            const glm::vec3 q = ray.origin + ray.dir * shadowed.depth[i] + shadowed.normal[i] * (0.75f * voxel);
            bool brute = false;
            for (int k = 1; k < 800 && !brute; ++k) {
                const glm::vec3 x = q + towards * (float(k) * 0.1f * voxel);
                brute = openvdb::tools::BoxSampler::sample(
                            acc, grid->transform().worldToIndex(openvdb::Vec3d(x.x, x.y, x.z))) < 0.f;
            }
            const bool renderer = lit.color[i].r - shadowed.color[i].r > 0.05f;
            ++checked;
            blocked += brute;
            disagree += brute != renderer;
        }
        EXPECT_GT(blocked, checked / 50) << checked;  // the big sphere's shadow on the small one
        EXPECT_LE(disagree, checked / 500) << blocked << " of " << checked;
        // And the whole image as marching every ray through the tree gives it, but for those rays.
        o.shadows = true;
        EXPECT_LT(meanColourDifference(shadowed,
                                       render::PreparedGrid(*grid, {render::IsoLayer{}}, true, false).render(look, o)),
                  0.004);
    }
}

TEST(Renderers, SmoothNormalsLeaningAwayFromTheViewerAreBentNotReversed) {
    // A quad facing +z whose vertex normals lean towards +y (as at a crease of a mesh), seen from
    // above and in front: the triangles face the camera but the smooth normal leans away from it.
    // It is bent until it just faces the viewer (reversing it, as before, shaded crease pixels as if
    // they faced the floor: black specks). From below and behind the triangles are seen from behind,
    // so the normal is reversed, then bent the same way.
    mesh::TriMesh quad;
    quad.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    quad.triangles = {{0, 1, 2}, {0, 2, 3}};
    const glm::vec3 lean = glm::normalize(glm::vec3(0.f, 1.f, 0.3f));
    quad.normals.assign(4, lean);
    auto o = small(64, 48);
    o.normal = true;
    const std::size_t centre = 24 * 64 + 32;
    for (const float opacity : {1.f, 0.5f}) {  // the packet path, and the one-ray path of translucent layers
        implicit::Material mat;
        mat.color.a = opacity;
        for (const float side : {1.f, -1.f}) {
            render::Look look;
            look.camera.eye = glm::vec3(0.f, -3.f * side, 3.f * side);
            look.camera.target = glm::vec3(0.f);
            look.camera.up = glm::vec3(0.f, 0.f, side);
            look.camera.fov = 30.f;
            const render::Frame f = render::renderMeshes({{&quad, mat, false}}, look, o);
            ASSERT_GE(f.color[centre].a, 0.99f);
            const glm::vec3 n = f.normal[centre], toEye = glm::normalize(look.camera.eye - glm::vec3(0.f));
            const std::string what = "opacity " + std::to_string(opacity) + ", side " + std::to_string(side) +
                                     ": normal " + std::to_string(n.x) + " " + std::to_string(n.y) + " " +
                                     std::to_string(n.z);
            EXPECT_NEAR(glm::length(n), 1.f, 1e-5f) << what;
            EXPECT_GT(glm::dot(n, side * lean), 0.8f) << what;  // the smooth normal's side, not reversed
            EXPECT_GT(glm::dot(n, toEye), 0.f) << what;         // facing the viewer
            EXPECT_LT(glm::dot(n, toEye), 0.05f) << what;       // only just: bent no further than needed
        }
    }
}

TEST(Renderers, PreparedMeshesRenderAnyViewAsOneCallWould) {
    // A real mesh (the cow) opaque, and a translucent sphere around part of it: both of Embree's
    // scenes (all objects, and the opaque ones that cast shadows) are built once.
    const mesh::TriMesh cow = mesh::readMesh(test::sourceDir() / "data/cow.obj");
    ASSERT_GT(cow.triangleCount(), 1000u);
    implicit::Box3 box;
    for (const auto& p : cow.positions) box = box.unite(implicit::Box3{p, p});
    const auto sphereGrid = volume::readFloatGrid(test::sourceDir() / "data/sphere.vdb");
    mesh::TriMesh shell = volume::extractIsosurface(*sphereGrid, volume::MeshingOptions{});
    const float scale = 0.25f * glm::length(box.size()) / 3.f;
    for (auto& p : shell.positions) p = box.centre() + scale * p;
    implicit::Material glass;
    glass.color = glm::vec4(0.3f, 0.5f, 0.9f, 0.4f);
    implicit::Material hide;
    hide.color = glm::vec4(0.8f, 0.6f, 0.5f, 1.f);
    const std::vector<render::MeshObject> objects{{&cow, hide, false}, {&shell, glass, false}};
    const render::PreparedMeshes prepared(objects);
    EXPECT_GE(prepared.setupSeconds(), 0.0);
    auto o = small(96, 72);
    o.depth = o.normal = o.objectId = true;
    for (const glm::vec3& dir : {glm::vec3(0.f, -1.f, 0.3f), glm::vec3(0.7f, 0.2f, -0.4f)}) {
        render::Look look;
        look.camera.target = box.centre();
        look.camera.eye = box.centre() + 1.5f * glm::length(box.size()) * glm::normalize(dir);
        look.camera.fov = 40.f;
        const render::Frame a = prepared.render(look, o);
        render::RenderStats st;
        const render::Frame b = render::renderMeshes(objects, look, o, &st);
        EXPECT_EQ(std::memcmp(a.color.data(), b.color.data(), a.color.size() * sizeof(glm::vec4)), 0);
        EXPECT_EQ(std::memcmp(a.depth.data(), b.depth.data(), a.depth.size() * sizeof(float)), 0);
        EXPECT_EQ(std::memcmp(a.normal.data(), b.normal.data(), a.normal.size() * sizeof(glm::vec3)), 0);
        EXPECT_EQ(a.objectId, b.objectId);
        EXPECT_GT(st.hitPixels, 0u);
        EXPECT_LE(st.setupSeconds, st.seconds);
        // Both objects seen.
        EXPECT_NE(std::find(a.objectId.begin(), a.objectId.end(), 1.f), a.objectId.end());
        EXPECT_NE(std::find(a.objectId.begin(), a.objectId.end(), 2.f), a.objectId.end());
    }
}

TEST(Renderers, PreparedGridRendersAnyViewAsOneCallWould) {
    const auto grid = volume::readFloatGrid(test::sourceDir() / "data/sphere.vdb");
    const render::PreparedGrid prepared(*grid, {render::IsoLayer{}}, true);
    EXPECT_GE(prepared.setupSeconds(), 0.0);
    for (const glm::vec3& from : {glm::vec3(0.f, -10.f, 3.f), glm::vec3(7.f, 2.f, -4.f)}) {
        render::Look look;
        look.camera.eye = from;
        look.camera.target = glm::vec3(0.f);
        look.camera.fov = 40.f;
        const auto o = small(96, 72);
        const render::Frame a = prepared.render(look, o);
        render::RenderStats st;
        const render::Frame b = render::marchGrid(*grid, {render::IsoLayer{}}, true, look, o, &st);
        EXPECT_EQ(std::memcmp(a.color.data(), b.color.data(), a.color.size() * sizeof(glm::vec4)), 0);
        EXPECT_GT(st.hitPixels, 0u);
        EXPECT_LE(st.setupSeconds, st.seconds);
    }
}

TEST(Shading, SpecularPowerAgreesWithPow) {
    // Whole exponents are raised by squaring: within about e ulps of std::pow (each squaring
    // doubles the relative error so far); other exponents are std::pow itself.
    for (float e : {0.f, 1.f, 2.f, 3.f, 10.f, 40.f, 100.f, 255.f, 1024.f})
        for (int i = 0; i <= 1000; ++i) {
            const float x = float(i) / 1000.f;
            const float want = std::pow(x, e), got = render::detail::specularPower(x, e);
            // Each squaring doubles the relative rounding error of the power so far: about e ulps.
            EXPECT_NEAR(got, want, want * (1e-6f + 1.2e-7f * e) + 1e-30f) << "x " << x << " e " << e;
        }
    for (float e : {0.5f, 7.5f, 1024.5f, 2048.f, -1.f})
        for (float x : {0.f, 0.25f, 0.9f, 1.f}) EXPECT_EQ(render::detail::specularPower(x, e), std::pow(x, e));
}

TEST(Shading, RayBlocksAreTheRaysOneByOne) {
    // The 16-lane generator gives bit for bit the rays of the one-ray generator.
    for (bool ortho : {false, true}) {
        render::Camera c;
        c.eye = glm::vec3(0.3f, -4.f, 2.f);
        c.target = glm::vec3(0.1f, 0.2f, -0.3f);
        c.orthographic = ortho;
        const render::detail::RayGenerator gen(c, 97, 61);
        float x[16], y[16];
        for (int k = 0; k < 16; ++k) x[k] = 3.5f + 5.25f * float(k), y[k] = 60.75f - 3.5f * float(k);
        render::detail::RayBlock b;
        gen.block(x, y, b);
        for (int k = 0; k < 16; ++k) {
            const render::detail::Ray r = gen(x[k], y[k]), s = b[k];
            EXPECT_EQ(std::memcmp(&r.origin, &s.origin, sizeof r.origin), 0) << k;
            EXPECT_EQ(std::memcmp(&r.dir, &s.dir, sizeof r.dir), 0) << k;
        }
    }
}

TEST(Renderers, EmbreePacketsShadeAsOneRayAtATime) {
    // The packet path (16 lanes shaded as structure of arrays) against a one-ray reference written
    // here from the documented model: Embree's single-ray queries, the interpolated vertex normal
    // facing the viewer, vertex colours or the material colour, secondary rays a quarter of the
    // mean edge (plus 1e-5 of the scene) off the surface, Blinn-Phong with hemispherical ambient.
    // Objects with different materials in one packet (a whole and a fractional shininess), vertex
    // colours, directional and point lights, and more lights than the 8 that go in packets.
    mesh::TriMesh ball = meshOf(implicit::makeSphere(0.8f), 0.04f);
    for (const glm::vec3& p : ball.positions) ball.colors.push_back(0.5f + 0.5f * glm::normalize(p));
    const mesh::TriMesh ring =
        meshOf(implicit::makeTranslated(implicit::makeTorus(0.9f, 0.25f), glm::vec3(1.2f, 0.4f, 0.f)), 0.04f);
    const mesh::TriMesh floor = meshOf(
        implicit::makeTranslated(implicit::makeBox(glm::vec3(5.f, 4.f, 0.4f)), glm::vec3(0.f, 0.f, -1.1f)), 0.05f);
    implicit::Material ballMat, ringMat, floorMat;
    ringMat.color = glm::vec4(0.9f, 0.6f, 0.2f, 1.f);
    ringMat.shininess = 7.5f;
    ringMat.specular = 0.6f;
    floorMat.color = glm::vec4(0.8f, 0.8f, 0.75f, 1.f);
    floorMat.diffuse = 0.7f;
    const std::vector<render::MeshObject> objs = {
        {&ball, ballMat, true}, {&ring, ringMat, false}, {&floor, floorMat, false}};
    implicit::Box3 box;
    for (const auto& obj : objs)
        for (const glm::vec3& p : obj.mesh->positions) box = box.unite(implicit::Box3{p, p});

    RTCDevice dev = rtcNewDevice(nullptr);
    RTCScene scene = rtcNewScene(dev);
    rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
    std::vector<float> offsets;
    for (const auto& obj : objs) {
        const mesh::TriMesh& m = *obj.mesh;
        RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* v = static_cast<float*>(
            rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, m.positions.size()));
        std::memcpy(v, m.positions.data(), 12 * m.positions.size());
        auto* t = static_cast<unsigned*>(
            rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, m.triangles.size()));
        std::memcpy(t, m.triangles.data(), 12 * m.triangles.size());
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
        double edges = 0;
        for (const auto& tr : m.triangles)
            edges += double(glm::length(m.positions[tr.y] - m.positions[tr.x])) +
                     glm::length(m.positions[tr.z] - m.positions[tr.y]) +
                     glm::length(m.positions[tr.x] - m.positions[tr.z]);
        offsets.push_back(float(0.25 * edges / (3.0 * double(m.triangles.size()))));
    }
    rtcCommitScene(scene);
    const float eps = 1e-5f * glm::length(box.size());
    auto occluded = [&](const glm::vec3& o, const glm::vec3& d, float tfar) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        RTCRay r{o.x, o.y, o.z, 0.f, d.x, d.y, d.z, 0.f, tfar, 0xFFFFFFFFu, 0, 0};
        rtcOccluded1(scene, &ctx, &r);
        return r.tfar < 0.f;
    };

    const int w = 128, h = 96;
    auto o = small(w, h);
    for (int rig = 0; rig < 2; ++rig) {
        render::Look look;
        look.camera = render::frameBox(box, float(w) / float(h), glm::vec3(-0.4f, 1.f, -0.6f));
        look.lights = {render::Light{false, glm::vec3(-1.f, 1.f, -1.5f), glm::vec3(1.f), 0.8f},
                       render::Light{true, glm::vec3(1.5f, -2.f, 2.5f), glm::vec3(1.f, 0.9f, 0.8f), 0.7f}};
        if (rig == 1)  // ten lights: the last two are tested one ray at a time
            for (int i = 0; i < 8; ++i)
                look.lights.push_back({i % 2 == 0,
                                       glm::vec3(std::cos(float(i)), std::sin(float(i)), 2.f - 0.3f * float(i)),
                                       glm::vec3(0.1f), 1.f});
        const render::Frame f = render::renderMeshes(objs, look, o);
        const render::detail::RayGenerator gen(look.camera, w, h);
        const render::detail::LightSet lights(look);
        const render::detail::Background background(look);
        double worst = 0;
        int hits[3] = {};
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const render::detail::Ray ray = gen(float(x) + 0.5f, float(y) + 0.5f);
                RTCIntersectContext ctx;
                rtcInitIntersectContext(&ctx);
                RTCRayHit rh{};
                rh.ray = {ray.origin.x,
                          ray.origin.y,
                          ray.origin.z,
                          0.f,
                          ray.dir.x,
                          ray.dir.y,
                          ray.dir.z,
                          0.f,
                          std::numeric_limits<float>::infinity(),
                          0xFFFFFFFFu,
                          0,
                          0};
                rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                rtcIntersect1(scene, &ctx, &rh);
                glm::vec3 want = background.at(float(y) + 0.5f, h);
                if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
                    ++hits[rh.hit.geomID];
                    const render::MeshObject& obj = objs[rh.hit.geomID];
                    const mesh::TriMesh& m = *obj.mesh;
                    const glm::uvec3 tri = m.triangles[rh.hit.primID];
                    const float u = rh.hit.u, v = rh.hit.v, wgt = 1.f - u - v;
                    glm::vec3 n = glm::normalize(wgt * m.normals[tri.x] + u * m.normals[tri.y] + v * m.normals[tri.z]);
                    if (glm::dot(glm::vec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z), ray.dir) > 0.f) n = -n;
                    n = render::detail::bendTowardsViewer(n, ray.dir);
                    render::detail::Surface s;
                    s.position = ray.origin + rh.ray.tfar * ray.dir;
                    s.normal = n;
                    s.albedo =
                        obj.vertexColors
                            ? render::srgbToLinear(wgt * m.colors[tri.x] + u * m.colors[tri.y] + v * m.colors[tri.z])
                            : render::srgbToLinear(glm::vec3(obj.material.color));
                    s.setMaterial(obj.material);
                    const glm::vec3 origin = s.position + n * (eps + offsets[rh.hit.geomID] + 1e-5f * rh.ray.tfar);
                    want = render::detail::shade(s, ray.dir, lights, look.ambient, 1.f,
                                                 [&](std::size_t li, const glm::vec3& L) {
                                                     return !occluded(origin, L, lights.reach(li, origin));
                                                 });
                }
                const glm::vec4 got = f.color[std::size_t(y) * w + std::size_t(x)];
                for (int c = 0; c < 3; ++c) worst = std::max(worst, double(std::abs(got[c] - want[c])));
            }
        for (int k = 0; k < 3; ++k) EXPECT_GT(hits[k], 250) << "object " << k;
        // Measured 1e-6: the two paths normalize the half vector in different orders.
        EXPECT_LT(worst, 1e-4) << "rig " << rig;
    }
    rtcReleaseScene(scene);
    rtcReleaseDevice(dev);
}

TEST(Renderers, GridsOfConstantTilesRenderAsBruteForceFinds) {
    // A fog volume made only of 8^3 tiles, each with its own constant value (a radial ramp): the
    // iso-surface runs between tiles, where the trilinear field blends their values. Quantized to
    // 1,000 distinct values, the region table shares one block per value; with 9,261 distinct values
    // it is not built (over its cap) and every fetch goes through the accessor. Both as brute force.
    for (int levels : {1000, 0}) {
        auto fog = openvdb::FloatGrid::create(0.f);
        fog->setGridClass(openvdb::GRID_FOG_VOLUME);
        fog->setTransform(openvdb::math::Transform::createLinearTransform(0.1));
        std::vector<float> values;
        for (int i = -10; i <= 10; ++i)
            for (int j = -10; j <= 10; ++j)
                for (int k = -10; k <= 10; ++k) {
                    float v = std::max(0.f, 1.f - std::sqrt(float(i * i + j * j + k * k)) / 10.f) +
                              1e-4f * float((i + 10) * 441 + (j + 10) * 21 + (k + 10)) / 9261.f;
                    if (levels) v = std::round(v * float(levels)) / float(levels);
                    fog->tree().addTile(1, openvdb::Coord(8 * i, 8 * j, 8 * k), v, true);
                    values.push_back(v);
                }
        std::sort(values.begin(), values.end());
        const auto distinct = std::unique(values.begin(), values.end()) - values.begin();
        EXPECT_EQ(distinct > 4096, levels == 0) << distinct << " distinct tile values";
        render::IsoLayer layer;
        layer.iso = 0.45f;
        const int w = 120, h = 90;
        auto o = small(w, h);
        o.depth = true;
        render::Look look;
        look.camera =
            render::frameBox({glm::vec3(-4.5f), glm::vec3(4.5f)}, float(w) / float(h), glm::vec3(0.3f, 1.f, 0.2f));
        const render::Frame fast = render::PreparedGrid(*fog, {layer}, false).render(look, o);
        const render::detail::RayGenerator gen(look.camera, w, h);
        std::size_t checked = 0, hits = 0, hitsDiffer = 0, depthsDiffer = 0;
        for (std::size_t i = 0; i < fast.pixels(); i += 3) {
            const auto [bt, bl] = bruteFirstHit(*fog, {layer}, false, gen(float(i % w) + 0.5f, float(i / w) + 0.5f));
            const bool fastHit = std::isfinite(fast.depth[i]);
            ++checked;
            hits += fastHit;
            if (fastHit != (bl >= 0)) {
                ++hitsDiffer;
                continue;
            }
            if (fastHit) depthsDiffer += std::abs(fast.depth[i] - bt) > 0.01f;  // a tenth of a voxel
        }
        EXPECT_GT(hits, checked / 8) << levels;
        EXPECT_LE(hitsDiffer, checked / 500) << levels;
        EXPECT_LE(depthsDiffer, checked / 200) << levels;
    }
}
