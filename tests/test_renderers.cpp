// The renderers: silhouettes against analytic shapes, the Embree and ray-marching paths against
// each other, grids, translucency, degenerate inputs, determinism and golden images.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <optional>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "csg/nodes.h"
#include "csg/scene.h"
#include "implicit/primitives.h"
#include "render/embree_renderer.h"
#include "render/grid_march.h"
#include "render/image.h"
#include "render/ray_march.h"
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
    const mesh::TriMesh m = meshOf(s.root, 0.005f);
    // One object per material, as the CLI does.
    std::vector<mesh::TriMesh> parts(3);
    std::vector<implicit::Material> mats(3);
    std::vector<const implicit::Material*> seen;
    for (const auto& t : m.triangles) {
        const implicit::Material* mat =
            s.root->materialAt((m.positions[t.x] + m.positions[t.y] + m.positions[t.z]) / 3.f);
        std::size_t k = std::find(seen.begin(), seen.end(), mat) - seen.begin();
        if (k == seen.size()) {
            ASSERT_LT(k, 3u);
            seen.push_back(mat);
            mats[k] = *mat;
        }
        const auto base = static_cast<unsigned>(parts[k].positions.size());
        for (int c = 0; c < 3; ++c) {
            parts[k].positions.push_back(m.positions[t[c]]);
            parts[k].normals.push_back(m.normals[t[c]]);
        }
        parts[k].triangles.emplace_back(base, base + 1, base + 2);
    }
    std::vector<render::MeshObject> objs;
    for (std::size_t k = 0; k < parts.size(); ++k) objs.push_back({&parts[k], mats[k], false});
    const render::Frame cast = render::renderMeshes(objs, look, o);
    const double overlap = iou(marched, cast), diff = meanColourDifference(marched, cast);
    EXPECT_GE(overlap, 0.995);
    // Measured 0.004-0.006: normals from the field's gradient vs interpolated mesh normals, and
    // shadow edges a voxel apart. 0.02 is about 5 levels of 8-bit sRGB in mid-grey.
    EXPECT_LT(diff, 0.02) << "IoU " << overlap;
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
    std::optional<render::Frame> first, firstMesh;
    for (int threads : {1, 2, 4}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        const render::Frame f = render::marchField(s.root, s.root->bounds().expanded(0.05f), look, o);
        const render::Frame g = render::renderMeshes({{&m, {}, false}}, look, o);
        if (!first) {
            first = f;
            firstMesh = g;
            continue;
        }
        EXPECT_EQ(std::memcmp(first->color.data(), f.color.data(), f.color.size() * sizeof(glm::vec4)), 0);
        EXPECT_EQ(std::memcmp(firstMesh->color.data(), g.color.data(), g.color.size() * sizeof(glm::vec4)), 0);
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
