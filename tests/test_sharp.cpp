// Feature vertices (--sharp: volume/sharpen.cpp) and simplification within a bound (--max-error:
// mesh/simplify.cpp) on CSG scenes: every guarantee of the marching cubes mesh kept, features placed.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <tbb/global_control.h>
#include <glm/common.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <gtest/gtest.h>

#include "csg/scene.h"
#include "csg/shapes.h"
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
}  // namespace

namespace {
/// The scene meshed with feature vertices, in world units (voxel scale), checked like every mesh.
mesh::TriMesh sharpMesh(const std::string& text, float voxel, volume::SharpenStats* stats = nullptr) {
    const auto scene = csg::parseScene(text, "sharp.isf");
    volume::SampleOptions o;
    o.voxelSize = voxel;
    auto grid = volume::sample(scene.root, o);
    volume::MeshingOptions mo;
    mo.worldSpace = false;
    mesh::TriMesh m = volume::extractIsosurface(*grid, mo);
    volume::sharpen(m, volume::pointwise([&](const glm::vec3& p) { return scene.root->value(p * voxel); }), stats);
    for (auto& p : m.positions) p *= voxel;
    return m;
}
/// A box turned off the grid (10, 20, 30 degrees about x, y, z), meshed at voxel 0.1 with and
/// without feature vertices, and the turn that places its corners.
struct TurnedBox {
    float voxel = 0.1f;
    volume::SharpenStats stats;
    mesh::TriMesh sharp, plain;
    glm::mat4 turn;
};
TurnedBox turnedBox() {
    const std::string box = "rotate([10, 20, 30]) cube([6, 5, 4], center = true);";
    TurnedBox b;
    b.sharp = sharpMesh(box, b.voxel, &b.stats);
    volume::SampleOptions o;
    o.voxelSize = b.voxel;
    b.plain = volume::extractIsosurface(*volume::sample(csg::parseScene(box, "b.isf").root, o));
    b.turn = glm::rotate(glm::mat4(1.f), glm::radians(30.f), glm::vec3(0, 0, 1)) *
             glm::rotate(glm::mat4(1.f), glm::radians(20.f), glm::vec3(0, 1, 0)) *
             glm::rotate(glm::mat4(1.f), glm::radians(10.f), glm::vec3(1, 0, 0));
    return b;
}
double nearestVertex(const mesh::TriMesh& m, const glm::vec3& q) {
    double best = 1e30;
    for (const auto& p : m.positions) best = std::min(best, double(glm::length(p - q)));
    return best;
}
}  // namespace

TEST(Sharp, FeatureVerticesKeepEveryGuaranteeOnEveryShapeFamily) {
    const std::vector<std::string> scenes = {
        "difference() { cube([10, 10, 10], center = true); rotate([30, 20, 10]) cube([4, 4, 20], center = true); }",
        "rotate([10, 20, 30]) cube([6, 5, 4], center = true);",
        "union() { sphere(4); rotate([90, 0, 0]) cylinder(r = 2, h = 12, center = true); }",
        "intersection() { sphere(5); rotate([15, 25, 0]) cube(7, center = true); }",
        "rotate([5, 10, 0]) cylinder(r = 4, h = 6, $fn = 12);",
        "rotate([0, 0, 10]) polyhedron(points = [[4,0,0],[-4,0,0],[0,4,0],[0,-4,0],[0,0,4],[0,0,-4]], faces = "
        "[[0,4,2],[0,2,5],[0,3,4],[0,5,3],[1,2,4],[1,5,2],[1,4,3],[1,3,5]]);",
        "torus(4, 1.5);",
        "smooth_union(k = 1) { sphere(3); translate([4, 0, 0]) sphere(3); }",
    };
    for (const std::string& s : scenes)
        for (float voxel : {0.37f, 0.19f, 0.11f}) {
            volume::SharpenStats stats;
            const mesh::TriMesh m = sharpMesh(s, voxel, &stats);
            test::expectClosedSurface(m, s + " at " + std::to_string(voxel));  // includes no self-intersections
        }
    // Smooth shapes have nothing to sharpen: the torus and the blend stay as marching cubes made them.
    volume::SharpenStats smooth;
    sharpMesh("torus(4, 1.5);", 0.19f, &smooth);
    EXPECT_EQ(smooth.features, 0u);
}

TEST(Sharp, CornersOfATurnedBoxGetTheirVertex) {
    // A box turned off the grid: marching cubes cuts its corners by up to a voxel; the feature
    // vertex of the corner cell is the corner itself (rank 3 Hermite data).
    const TurnedBox b = turnedBox();
    const auto& [voxel, stats, sharp, plain, turn] = b;
    EXPECT_GT(stats.features, 100u);
    double sumSharp = 0, sumPlain = 0;
    for (int k = 0; k < 8; ++k) {
        const glm::vec3 corner(turn *
                               glm::vec4((k & 1) ? 3.f : -3.f, (k & 2) ? 2.5f : -2.5f, (k & 4) ? 2.f : -2.f, 1.f));
        sumSharp += nearestVertex(sharp, corner);
        sumPlain += nearestVertex(plain, corner);
    }
    // Printed for the record; asserted: the corners come nearer (not yet every one onto its corner:
    // some corner cells' feature points fall outside the cell, where the cell keeps its triangles).
    std::printf("corners: mean distance to the nearest vertex %.3f voxels with --sharp, %.3f without\n",
                sumSharp / 8 / voxel, sumPlain / 8 / voxel);
    EXPECT_LT(sumSharp, 0.6 * sumPlain) << "features " << stats.features << ", kept " << stats.kept;
}

TEST(Sharp, CreasesRunAlongTheEdgesOfATurnedBox) {
    // Points along the twelve edges of a box turned off the grid, and their distance to the mesh:
    // marching cubes cuts every edge by about a third of a voxel; feature vertices and crease flips
    // put the mesh's creases on them.
    const TurnedBox b = turnedBox();
    const auto& [voxel, stats, sharp, plain, turn] = b;
    EXPECT_GT(stats.flips, 100u);
    const auto toSharp = csg::makeTriangleMeshField(sharp.positions, sharp.triangles, "sharp", nullptr, true);
    const auto toPlain = csg::makeTriangleMeshField(plain.positions, plain.triangles, "plain", nullptr, true);
    const glm::vec3 halfSize(3.f, 2.5f, 2.f);
    double sumSharp = 0, sumPlain = 0;
    int n = 0;
    for (int axis = 0; axis < 3; ++axis)
        for (int corner = 0; corner < 4; ++corner)
            for (int step = 1; step < 40; ++step) {  // the edge without its ends (corners are another test)
                glm::vec3 p;
                p[axis] = -halfSize[axis] + 2.f * halfSize[axis] * float(step) / 40.f;
                p[(axis + 1) % 3] = (corner & 1) ? halfSize[(axis + 1) % 3] : -halfSize[(axis + 1) % 3];
                p[(axis + 2) % 3] = (corner & 2) ? halfSize[(axis + 2) % 3] : -halfSize[(axis + 2) % 3];
                const glm::vec3 q(turn * glm::vec4(p, 1.f));
                sumSharp += std::abs(toSharp->value(q));
                sumPlain += std::abs(toPlain->value(q));
                ++n;
            }
    std::printf("edges: mean distance to the mesh %.3f voxels with --sharp, %.3f without\n", sumSharp / n / voxel,
                sumPlain / n / voxel);
    EXPECT_LT(sumSharp / n, 0.1 * voxel);
    EXPECT_GT(sumPlain / n, 0.25 * voxel);
}

TEST(Sharp, RidgesWhoseChamferLeansAwayGetTheirFeatureVertices) {
    // A sphere with a cylindrical hole (OpenSCAD's example001 in small): its rims are ridges of 60 degrees,
    // here high in their layer of cells (z = 43.87 voxels), as example001's are at 256 voxels. Marching cubes'
    // chamfer of a rim cell leans away from the ridge, so across the chamfer's own normal the ridge point lies
    // outside the patch; across the Hermite normals' mean, or across one of the two faces, the fan is still a
    // graph, and the cell gets its feature vertex. Before: mean 0.130 voxels, worst 0.608, 168 cells kept.
    // (Rims low in their layer stay about 0.16 voxels off: the wedge there is thinner than a voxel where it
    // meets the grid plane below, and marching cubes misses it between two grid points.)
    const std::string scene = "difference() { sphere(5); cylinder(r = 2.5, h = 20, center = true); }";
    const float rimZ = std::sqrt(25.f - 6.25f), voxel = 0.0987f;
    volume::SharpenStats stats;
    const mesh::TriMesh m = sharpMesh(scene, voxel, &stats);
    test::expectClosedSurface(m, scene);
    const auto toMesh = csg::makeTriangleMeshField(m.positions, m.triangles, "sharp", nullptr, true);
    double sum = 0, worst = 0;
    int n = 0;
    for (float z : {-rimZ, rimZ})
        for (int k = 0; k < 400; ++k) {
            const float a = 2.f * float(M_PI) * (float(k) + 0.5f) / 400.f;
            const double d = std::abs(toMesh->value(glm::vec3(2.5f * std::cos(a), 2.5f * std::sin(a), z)));
            sum += d;
            worst = std::max(worst, d);
            ++n;
        }
    std::printf("rims: mean distance to the mesh %.3f voxels, worst %.3f; %zu feature vertices, %zu cells kept\n",
                sum / n / voxel, worst / voxel, stats.features, stats.kept);
    EXPECT_LT(sum / n, 0.08 * voxel);
    EXPECT_LT(worst, 0.3 * voxel);
    EXPECT_LT(stats.kept, 20u);
}

TEST(Sharp, ThinWedgesAndTipsThatNoGridEdgeCrossesAreReached) {
    // A frustum widening from 20 to 60 over a height of 10 (OpenSCAD's linear_extrude with scale = 3): its top
    // edges are wedges of 14 degrees, whose last voxels hold no grid point, so no grid edge crosses them and
    // marching cubes stops short (1.5 voxels here). A cone's rim (34 degrees, OpenSCAD's example005) the same.
    // Their cells' feature points lie beyond the cells, in empty cells, which the fans now reach: the top
    // edges at 60.1 and 60.05 came out at 59.54 and 59.49 before, the cone's vertex at 12.1 at 11.74.
    struct Case {
        std::string scene;
        glm::vec3 lo, hi;  // the solid's exact bounding box
    };
    const float voxel = 0.37f;
    const std::vector<Case> cases = {
        {"translate([0.1, 0.05, 0.13]) linear_extrude(height = 10, scale = 3) square(20);",
         glm::vec3(0.1f, 0.05f, 0.13f), glm::vec3(60.1f, 60.05f, 10.13f)},
        {"translate([0.1, 0.05, 0.13]) cylinder(h = 8, r1 = 12, r2 = 0, $fn = 96);", glm::vec3(-11.9f, -11.95f, 0.13f),
         glm::vec3(12.1f, 12.05f, 8.13f)},
    };
    for (const Case& c : cases) {
        volume::SharpenStats stats;
        const mesh::TriMesh m = sharpMesh(c.scene, voxel, &stats);
        test::expectClosedSurface(m, c.scene);  // includes no self-intersections
        EXPECT_GT(stats.reached, 10u) << c.scene;
        glm::vec3 lo(1e30f), hi(-1e30f);
        for (const glm::vec3& p : m.positions) {
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
        }
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(lo[k], c.lo[k], 0.05f * voxel) << c.scene << " axis " << k;
            EXPECT_NEAR(hi[k], c.hi[k], 0.05f * voxel) << c.scene << " axis " << k;
        }
    }
}

TEST(Sharp, ReachingFansKeepEveryGuaranteeWhereverTheGridFalls) {
    // Thin wedges and tips turned every which way and meshed at several voxel sizes: fans reaching into
    // empty cells compete for them (boxes granted once, in key order) beside flipped creases; every mesh
    // stays closed, manifold, oriented and free of intersecting pairs.
    const std::vector<std::string> shapes = {
        "linear_extrude(height = 2, scale = 4) square(1, center = true);",  // 14-degree edges, 4 wedge corners
        "cylinder(h = 3, r1 = 2, r2 = 0, $fn = 7);",                        // a 34-degree rim and an apex
        "difference() { cube(3, center = true); rotate([0, 0, 3]) translate([0.2, 0, 0]) cube([3, 1, 4], "
        "center = true); }",  // slivers between a slot and the cube's faces
    };
    std::size_t reached = 0;
    int n = 0;
    for (const std::string& shape : shapes)
        for (int turn = 0; turn < 3; ++turn)
            for (float voxel : {0.13f, 0.071f}) {
                const std::string scene = "rotate([" + std::to_string(17 * turn + 5) + ", " +
                                          std::to_string(31 * turn) + ", " + std::to_string(7 * turn + 2) + "]) " +
                                          shape;
                volume::SharpenStats stats;
                const mesh::TriMesh m = sharpMesh(scene, voxel, &stats);
                test::expectClosedSurface(m, scene + " at " + std::to_string(voxel));
                reached += stats.reached;
                ++n;
            }
    std::printf("%zu fans reached beyond their cells in %d meshes\n", reached, n);
    EXPECT_GT(reached, std::size_t(5 * n));  // the competition for cells is exercised
    // The same bytes on 1, 2 and 3 threads (boxes are granted serially, in cell key order).
    const std::string turned = "rotate([22, 31, 9]) " + shapes[0];
    volume::SharpenStats one;
    mesh::TriMesh reference;
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
        reference = sharpMesh(turned, 0.071f, &one);
    }
    EXPECT_GT(one.reached, 0u);
    for (int threads : {2, 3}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        const mesh::TriMesh m = sharpMesh(turned, 0.071f);
        EXPECT_EQ(m.positions, reference.positions) << threads << " threads";
        EXPECT_EQ(m.triangles, reference.triangles) << threads << " threads";
    }
}

TEST(Simplify, FewerTrianglesWithinTheBoundAndEveryGuarantee) {
    // A smooth sphere (plain marching cubes) and a turned box with feature vertices, simplified within a
    // quarter voxel: closed, manifold, oriented, no intersecting pair (expectClosedSurface), far fewer
    // triangles, and every vertex of the full mesh within the bound of the simplified one.
    struct Case {
        std::string scene;
        float voxel;
        bool sharp;
    };
    for (const Case& c :
         {Case{"sphere(1);", 0.05f, false}, Case{"rotate([10, 20, 30]) cube([6, 5, 4], center = true);", 0.1f, true}}) {
        mesh::TriMesh full;
        if (c.sharp) {
            full = sharpMesh(c.scene, c.voxel);
        } else {
            const auto scene = csg::parseScene(c.scene, "s.isf");
            volume::SampleOptions o;
            o.voxelSize = c.voxel;
            full = volume::extractIsosurface(*volume::sample(scene.root, o));
        }
        mesh::TriMesh simple = full;
        const double bound = 0.25 * c.voxel;
        const mesh::SimplifyStats stats = mesh::simplify(simple, bound);
        EXPECT_GT(stats.collapses, 0u);
        test::expectClosedSurface(simple, c.scene + " simplified");
        EXPECT_LT(simple.triangleCount() * 5, full.triangleCount())
            << c.scene << ": " << full.triangleCount() << " -> " << simple.triangleCount();
        const auto toSimple = csg::makeTriangleMeshField(simple.positions, simple.triangles, "simple", nullptr, true);
        double worst = 0;
        for (const auto& p : full.positions) worst = std::max(worst, double(std::abs(toSimple->value(p))));
        EXPECT_LE(worst, bound * 1.001) << c.scene;
        // Deterministic: the same input gives the same mesh.
        mesh::TriMesh again = full;
        mesh::simplify(again, bound);
        EXPECT_EQ(again.positions, simple.positions);
        EXPECT_EQ(again.triangles, simple.triangles);
    }
}

TEST(Sharp, SameBytesWhateverTheThreadCount) {
    // The whole --sharp --max-error pipeline (volume::meshSurface, what `isoforge mesh` and Python call):
    // the same vertices and triangles on 1, 2 and 3 threads.
    const auto scene =
        csg::parseScene("difference() { rotate([10, 20, 30]) cube([6, 5, 4], center = true); sphere(2.8); }", "d.isf");
    volume::SampleOptions so;
    so.voxelSize = 0.2f;
    volume::SurfaceOptions o;
    o.sharp = true;
    o.maxError = 0.04;
    mesh::TriMesh reference;
    for (int threads : {1, 2, 3}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        const mesh::TriMesh m = volume::meshSurface(*volume::sample(scene.root, so), scene.root, o);
        if (threads == 1) {
            reference = m;
            test::expectClosedSurface(m, "sharp and simplified");
            continue;
        }
        EXPECT_EQ(m.positions, reference.positions) << threads << " threads";
        EXPECT_EQ(m.triangles, reference.triangles) << threads << " threads";
    }
    // Many coloured, nested children (OpenSCAD's testcolornames, smaller): each thread keeps the field
    // pruned to the blocks it visits (volume/surface.cpp); that changes no vertex and no colour.
    std::string text = "union() {";
    for (int i = 0; i < 40; ++i)
        text += " translate([" + std::to_string(i % 8) + ", " + std::to_string(i / 8) + ", 0]) color([" +
                std::to_string(0.1 * (i % 10)) + ", 0.5, 0.2]) sphere(r = 0.8, $fn = 5);";
    text += " }";
    const auto spheres = csg::parseScene(text, "s.isf");
    so.voxelSize = 0.06f;
    o.maxError = 0;
    for (int threads : {1, 2, 3}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        const mesh::TriMesh m = volume::meshSurface(*volume::sample(spheres.root, so), spheres.root, o);
        if (threads == 1) {
            reference = m;
            test::expectClosedSurface(m, "sharp spheres");
            EXPECT_EQ(m.colors.size(), m.positions.size());
            continue;
        }
        EXPECT_EQ(m.positions, reference.positions) << threads << " threads";
        EXPECT_EQ(m.triangles, reference.triangles) << threads << " threads";
        EXPECT_EQ(m.colors, reference.colors) << threads << " threads";
    }
}
