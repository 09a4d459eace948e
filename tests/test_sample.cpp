#include <cmath>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <tbb/global_control.h>
#include "core/error.h"
#include "implicit/blobby.h"
#include "implicit/primitives.h"
#include "implicit/quadric.h"
#include "implicit/tape.h"
#include "test_util.h"
#include "volume/leaf_sampler.h"
#include "volume/marching_cubes.h"
#include "volume/sample.h"
#include "volume/vdb_io.h"

using namespace isoforge;
using namespace isoforge::implicit;

namespace {

struct Init {
    Init() { volume::initializeOpenVdb(); }
} init;

mesh::TriMesh meshField(const FieldPtr& f, float voxel, const Box3& clip = Box3::everything(), float iso = 0.f,
                        volume::SampleStats* stats = nullptr) {
    volume::SampleOptions o;
    o.voxelSize = voxel;
    o.clip = clip;
    auto grid = volume::sample(f, o, stats);
    volume::MeshingOptions m;
    m.isovalue = iso;
    return volume::extractIsosurface(*grid, m);
}

}  // namespace

TEST(Sample, LevelSetValuesAreTheAnalyticDistances) {
    volume::SampleOptions o;
    o.voxelSize = 0.05f;
    auto grid = volume::sample(makeSphere(1.f), o);
    EXPECT_EQ(grid->getGridClass(), openvdb::GRID_LEVEL_SET);
    EXPECT_FLOAT_EQ(grid->background(), 0.15f);
    std::size_t n = 0;
    for (auto it = grid->cbeginValueOn(); it; ++it, ++n) {
        const openvdb::Vec3d p = grid->indexToWorld(it.getCoord());
        ASSERT_NEAR(*it, p.length() - 1.0, 1e-5);
        ASSERT_LT(std::abs(*it), 0.15f);
    }
    EXPECT_GT(n, 10000u);
    // Inside is filled: the centre reads as inside.
    EXPECT_FLOAT_EQ(grid->tree().getValue(openvdb::Coord(0)), -0.15f);
}

TEST(Sample, EveryPrimitiveMeshesClosedAndOrientedAtTwoResolutions) {
    const std::vector<std::pair<FieldPtr, long long>> shapes = {{makeSphere(0.8f), 0},
                                                                {makeBox({1.f, 0.6f, 0.4f}), 0},
                                                                {makeBox({1.f, 1.f, 1.f}, 0.2f), 0},
                                                                {makeCylinder(0.5f, 1.2f), 0},
                                                                {makeCone(0.6f, 0.1f, 1.f), 0},
                                                                {makeCone(0.6f, 0.f, 1.f), 0},
                                                                {makeTorus(0.7f, 0.2f), 1},
                                                                {makeCapsule(0.3f, 0.8f), 0},
                                                                {makeTetrahedron(0.6f), 0},
                                                                {makeEllipsoid({0.9f, 0.5f, 0.3f}), 0},
                                                                {makeShell(makeSphere(0.7f), 0.1f), 0},
                                                                {makeOffset(makeTorus(0.6f, 0.1f), 0.05f), 1}};
    for (const auto& [f, genus] : shapes)
        for (float voxel : {0.04f, 0.017f}) {
            const auto r = test::expectClosedSurface(meshField(f, voxel), f->describe());
            EXPECT_EQ(r.genus().value_or(-1), genus) << f->describe();
        }
}

TEST(Sample, VolumesMatchAnalyticValues) {
    const float voxel = 0.01f;
    auto r = test::expectClosedSurface(meshField(makeSphere(0.5f), voxel), "sphere");
    EXPECT_NEAR(r.volume, 4.0 / 3.0 * M_PI * 0.125, 0.005 * 0.5236);
    r = test::expectClosedSurface(meshField(makeTorus(0.6f, 0.2f), voxel), "torus");
    EXPECT_NEAR(r.volume, 2 * M_PI * M_PI * 0.6 * 0.04, 0.01 * 0.4737);
    r = test::expectClosedSurface(meshField(makeCylinder(0.3f, 0.8f), voxel), "cylinder");
    EXPECT_NEAR(r.volume, M_PI * 0.09 * 0.8, 0.01 * 0.226);
    r = test::expectClosedSurface(meshField(makeCone(0.4f, 0.2f, 0.6f), voxel), "cone");
    EXPECT_NEAR(r.volume, M_PI * 0.6 / 3 * (0.16 + 0.08 + 0.04), 0.01 * 0.176);
    r = test::expectClosedSurface(meshField(makeEllipsoid({0.5f, 0.3f, 0.2f}), voxel), "ellipsoid");
    EXPECT_NEAR(r.volume, 4.0 / 3.0 * M_PI * 0.03, 0.01 * 0.1257);
    r = test::expectClosedSurface(meshField(makeTetrahedron(0.5f), voxel), "tetrahedron");
    EXPECT_NEAR(r.volume, 8.0 * 0.125 / 3.0, 0.02 * 0.333);
}

TEST(Sample, QuadricsAlgebraicSurfacesAndBlobsAreClosed) {
    const Box3 box{glm::vec3(-1.f), glm::vec3(1.f)};
    for (const std::string& type : quadricTypes()) {
        auto m = meshField(makeNamedQuadric(type, 0.5f, 0.4f, 0.6f), 0.03f, box);
        test::expectClosedSurface(m, "quadric " + type);
    }
    const Box3 big{glm::vec3(-3.f), glm::vec3(3.f)};
    const std::vector<std::pair<std::string, long long>> algebraic = {
        {"x^4 - 5*x^2 + y^4 - 5*y^2 + z^4 - 5*z^2 + 11.8", 5},             // Goursat's tangle cube
        {"(x^2 + y^2 + z^2 + 0.8^2 - 0.3^2)^2 - 4*0.8^2*(x^2 + y^2)", 1},  // a quartic torus
        {"x^2 + y^2 + z^2 - 1 + 0.2*sin(6*x)*sin(6*y)*sin(6*z)", 0}};
    for (const auto& [e, genus] : algebraic) {
        auto f = makeTapeField(parseExpression(e), Box3::everything(), e);
        const auto r = test::expectClosedSurface(meshField(f, 0.04f, big), e);
        EXPECT_EQ(r.genus().value_or(-1), genus) << e;
    }
    for (BlobKernel k : {BlobKernel::Blinn, BlobKernel::Wyvill, BlobKernel::Metaball}) {
        auto close = makeBlobby({{{-0.3f, 0, 0}, 0.6f, 1.f}, {{0.3f, 0, 0}, 0.6f, 1.f}}, 0.5f, k);
        auto far = makeBlobby({{{-1.f, 0, 0}, 0.6f, 1.f}, {{1.f, 0, 0}, 0.6f, 1.f}}, 0.5f, k);
        EXPECT_EQ(test::expectClosedSurface(meshField(close, 0.02f), "close blobs").components, 1u);
        EXPECT_EQ(test::expectClosedSurface(meshField(far, 0.02f), "far blobs").components, 2u);
    }
}

TEST(Sample, VmModelsMatchTheirAnalyticMeaning) {
    // A sphere of radius 0.5, and a smooth union of two spheres written out in .vm ops.
    const std::string sphere =
        "_0 var-x\n_1 var-y\n_2 var-z\n_3 square _0\n_4 square _1\n_5 square _2\n"
        "_6 add _3 _4\n_7 add _6 _5\n_8 sqrt _7\n_9 const 0.5\n_a sub _8 _9\n";
    auto f = makeTapeField(parseVm(sphere, "sphere.vm"), Box3::everything(), "sphere.vm");
    auto r = test::expectClosedSurface(meshField(f, 0.01f, {glm::vec3(-1.f), glm::vec3(1.f)}), "sphere.vm");
    EXPECT_NEAR(r.volume, 4.0 / 3.0 * M_PI * 0.125, 0.005 * 0.5236);
    // smin(a, b) = min(a, b) - h^2 k / 4 with h = max(k - |a - b|, 0) / k, k = 0.2.
    const std::string pair =
        "_0 var-x\n_1 var-y\n_2 var-z\n_3 square _1\n_4 square _2\n_5 add _3 _4\n"
        "_6 const 0.35\n_7 sub _0 _6\n_8 square _7\n_9 add _8 _5\n_a sqrt _9\n_b const 0.3\n_c sub _a _b\n"
        "_d add _0 _6\n_e square _d\n_f add _e _5\n_10 sqrt _f\n_11 sub _10 _b\n"
        "_12 min _c _11\n_13 sub _c _11\n_14 abs _13\n_15 const 0.2\n_16 sub _15 _14\n_17 const 0\n"
        "_18 max _16 _17\n_19 const 5\n_1a mul _18 _19\n_1b square _1a\n_1c const 0.05\n_1d mul _1b _1c\n"
        "_1e sub _12 _1d\n";
    auto g = makeTapeField(parseVm(pair, "pair.vm"), Box3::everything(), "pair.vm");
    EXPECT_NEAR(g->value(glm::vec3(0.35f, 0.f, 0.f)), -0.3f, 1e-5f);  // far from the blend: the sphere
    EXPECT_LT(g->value(glm::vec3(0.f)), std::min(0.05f, 0.05f));      // the blend fills the gap
    r = test::expectClosedSurface(meshField(g, 0.01f, {glm::vec3(-1.f), glm::vec3(1.f)}), "pair.vm");
    EXPECT_EQ(r.components, 1u);
    const double two = 2 * 4.0 / 3.0 * M_PI * 0.027;
    EXPECT_GT(r.volume, two);  // more than two disjoint spheres: the blend adds material
}

TEST(Sample, ThinFeaturesSurvive) {
    const float voxel = 0.02f;
    // A shell 0.2 voxels thick and a needle 0.2 voxels wide: no block on them is skipped, so the band
    // holds them; meshed one voxel out (every surface point then has a voxel centre within reach)
    // they close around the feature.
    volume::SampleOptions o;
    o.voxelSize = voxel;
    auto shell = volume::sample(makeShell(makeSphere(0.5f), 0.2f * voxel), o);
    auto needle = volume::sample(makeCapsule(0.1f * voxel, 1.f), o);
    for (auto grid : {shell, needle}) {
        float lowest = 1e9f;
        for (auto it = grid->cbeginValueOn(); it; ++it) lowest = std::min(lowest, *it);
        EXPECT_LT(lowest, 0.6f * voxel);
    }
    volume::MeshingOptions m;
    m.isovalue = voxel;
    auto r = test::expectClosedSurface(volume::extractIsosurface(*shell, m), "thin shell");
    EXPECT_EQ(r.components, 2u);  // outer and inner skins of the thickened shell
    auto n = volume::extractIsosurface(*needle, m);
    r = test::expectClosedSurface(n, "needle");
    EXPECT_EQ(r.components, 1u);
    const auto b = mesh::bounds(n);
    EXPECT_GT(b.max.z - b.min.z, 0.98f);  // the whole length
}

TEST(Sample, WorkGrowsWithTheSurfaceNotTheVolume) {
    volume::SampleStats a, b;
    volume::SampleOptions o;
    o.voxelSize = 0.02f;
    volume::sample(makeSphere(1.f), o, &a);
    o.voxelSize = 0.01f;
    volume::sample(makeSphere(1.f), o, &b);
    const double ratio = double(b.pointsEvaluated) / double(a.pointsEvaluated);
    EXPECT_GT(ratio, 3.0);
    EXPECT_LT(ratio, 5.0);  // a dense sampler would do 8x
}

TEST(Sample, LeavesSampledCoarseToFineMatchEveryPointEvaluated) {
    // Beyond the band a leaf's points take +-band from a coarse neighbour; within it their own values.
    // Leaves along each surface (and one far outside), for distance fields of every kind and a blobby
    // field (which is not a distance and is sampled point by point).
    const float voxel = 0.02f, band = 3.f * voxel;
    const std::vector<std::pair<std::string, FieldPtr>> fields = {
        {"sphere", makeSphere(1.f)},
        {"box", makeBox(glm::vec3(1.6f, 1.2f, 0.8f))},
        {"torus", makeTorus(0.8f, 0.25f)},
        {"cone", makeCone(0.9f, 0.2f, 1.5f)},
        {"ellipsoid", makeEllipsoid(glm::vec3(1.f, 0.6f, 0.3f))},
        {"scaled offset", makeOffset(makeTransformed(makeCylinder(0.5f, 1.f),
                                                     glm::mat4(glm::vec4(1.5f, 0, 0, 0), glm::vec4(0, 1, 0, 0),
                                                               glm::vec4(0, 0, 0.7f, 0), glm::vec4(0.1f, 0, 0, 1))),
                                     0.05f)},
        {"blobby",
         makeBlobby({{glm::vec3(0.f), 0.7f, 1.f}, {glm::vec3(0.5f, 0.f, 0.f), 0.6f, 1.f}}, 0.5f, BlobKernel::Wyvill)},
    };
    for (const auto& [name, f] : fields) {
        volume::LeafSampler ls(voxel, band, f->isDistance());
        std::vector<glm::vec3> p(512);
        std::vector<float> all(512);
        std::size_t leaves = 0, clamped = 0;
        for (int k = 0; k <= 40; ++k) {
            // Leaves along a line through the field's box, the last one far outside.
            const glm::vec3 at = k == 40 ? glm::vec3(3.f) : glm::vec3(-1.2f + 0.06f * k, 0.013f * k, 0.01f * k);
            const openvdb::Coord c(8 * int(std::floor(at.x / voxel / 8)), 8 * int(std::floor(at.y / voxel / 8)),
                                   8 * int(std::floor(at.z / voxel / 8)));
            for (int i = 0; i < 512; ++i)
                p[i] = glm::vec3(c.x() + (i >> 6), c.y() + ((i >> 3) & 7), c.z() + (i & 7)) * voxel;
            f->values(p, all);
            const std::span<const float> got = ls.sample(*f, c);
            for (int i = 0; i < 512; ++i) {
                if (f->isDistance() && std::abs(all[i]) >= band && std::abs(got[i]) == band) {
                    ASSERT_EQ(got[i] < 0, all[i] < 0) << name << " leaf " << k << " point " << i;
                    ++clamped;
                } else {
                    ASSERT_EQ(got[i], all[i]) << name << " leaf " << k << " point " << i;
                }
            }
            ++leaves;
        }
        if (f->isDistance()) {
            EXPECT_GT(clamped, leaves * 512 / 4) << name;  // most points of these leaves are beyond the band
            EXPECT_LT(ls.evaluated(), leaves * 512 - clamped / 2) << name;
        } else {
            EXPECT_EQ(ls.evaluated(), leaves * 512) << name;
        }
    }
}

TEST(Sample, AbsurdRequestsAreRefusedWithAnEstimate) {
    volume::SampleOptions o;
    o.voxelSize = 2.f / 1e6f;  // a 10^6 resolution
    try {
        volume::sample(makeSphere(1.f), o);
        FAIL() << "expected a refusal";
    } catch (const ResourceError& e) {
        EXPECT_NE(std::string(e.what()).find("would need about"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("TiB"), std::string::npos) << e.what();
    }
    o.voxelSize = 0.01f;
    EXPECT_THROW(volume::sample(makePlane({0, 0, 1}, 0), o), std::invalid_argument);  // unbounded, no box
    o.voxelSize = 0.f;
    EXPECT_THROW(volume::sample(makeSphere(1.f), o), std::invalid_argument);
}

TEST(Sample, SameGridWhateverTheThreadCount) {
    auto f = makeTapeField(parseExpression("x^4 - 5*x^2 + y^4 - 5*y^2 + z^4 - 5*z^2 + 11.8"), Box3::everything(), "g");
    volume::SampleOptions o;
    o.voxelSize = 0.05f;
    o.clip = {glm::vec3(-3.f), glm::vec3(3.f)};
    auto a = volume::sample(f, o);
    mesh::TriMesh ma, mb;
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        auto b = volume::sample(f, o);
        mb = volume::extractIsosurface(*b);
    }
    ma = volume::extractIsosurface(*a);
    EXPECT_EQ(ma.positions, mb.positions);
    EXPECT_EQ(ma.triangles, mb.triangles);
}
