// Feature vertices and simplification beside plain marching cubes and OpenVDB's volumeToMesh, on the same
// grids: isoforge's meshSurface plain, with --sharp, and with --sharp --max-error of a quarter voxel;
// openvdb::tools::volumeToMesh with adaptivity 0 and 0.5 (quads counted as two triangles). For each: the
// median time of 3 calls (1 for the slow ones), triangles, millions of triangles per second, whether the
// mesh is closed, manifold and oriented, and its intersecting triangle pairs (exact predicates).
// Scenes: OpenSCAD exports and a turned box, sampled at 256 voxels along their longest side.
// Usage: bench_sharp [--quick]   (--quick: 128 voxels, one call each)
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <openvdb/tools/VolumeToMesh.h>

#include "bench_util.h"
#include "csg/scene.h"
#include "mesh/check.h"
#include "volume/sample.h"
#include "volume/surface.h"
#include "volume/vdb_io.h"

using namespace isoforge;

namespace {

mesh::TriMesh fromOpenVdb(const std::vector<openvdb::Vec3s>& points, const std::vector<openvdb::Vec3I>& tris,
                          const std::vector<openvdb::Vec4I>& quads) {
    mesh::TriMesh m;
    for (const auto& p : points) m.positions.emplace_back(p.x(), p.y(), p.z());
    // OpenVDB's winding is the opposite of ours (outward normals by the right-hand rule).
    for (const auto& t : tris) m.triangles.emplace_back(t.x(), t.z(), t.y());
    for (const auto& q : quads) {
        m.triangles.emplace_back(q.x(), q.z(), q.y());
        m.triangles.emplace_back(q.x(), q.w(), q.z());
    }
    return m;
}

}  // namespace

int main(int argc, char** argv) {
    bench::checkArguments(argc, argv, "Usage: bench_sharp [--quick]", {"--quick"});
    volume::initializeOpenVdb();
    const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
    const int resolution = quick ? 128 : 256;
    struct Input {
        std::string name;
        csg::Scene scene;
    };
    std::vector<Input> inputs;
    const std::string data = std::string(ISOFORGE_SOURCE_DIR) + "/tests/data/openscad/";
    inputs.push_back({"turned box", csg::parseScene("rotate([10, 20, 30]) cube([6, 5, 4], center = true);", "b.isf")});
    for (const char* file : {"hexnut.csg", "CSG.csg", "logo.csg"})
        inputs.push_back({file, csg::readScene(data + file)});

    std::printf(
        "| scene (%d voxels) | method | median s | triangles | Mtri/s | closed, manifold, oriented | "
        "intersecting pairs |\n",
        resolution);
    std::printf("|---|---|---:|---:|---:|---|---:|\n");
    for (const Input& in : inputs) {
        const implicit::Box3 box = in.scene.root->bounds();
        const glm::vec3 size = box.size();
        volume::SampleOptions so;
        so.voxelSize = std::max({size.x, size.y, size.z}) / float(resolution);
        const auto grid = volume::sample(in.scene.root, so);
        auto report = [&](const char* method, int calls, auto&& make) {
            bench::Samples t;
            mesh::TriMesh m;
            for (int i = 0; i < calls; ++i) {
                const double t0 = bench::now();
                m = make();
                t.seconds.push_back(bench::now() - t0);
            }
            mesh::CheckOptions co;
            co.selfIntersections = true;
            const mesh::MeshReport r = mesh::check(m, co);
            const bool closed = r.isWatertight() && r.isVertexManifold() && r.isOriented() && !r.hasDegenerates();
            std::printf("| %s | %s | %.3f | %zu | %.3g | %s | %zu |\n", in.name.c_str(), method, t.median(),
                        m.triangles.size(), double(m.triangles.size()) / t.median() / 1e6, closed ? "yes" : "no",
                        r.selfIntersections.pairs);
            std::fflush(stdout);
        };
        const int calls = quick ? 1 : 3;
        volume::SurfaceOptions plain, sharp, simplified;
        sharp.sharp = simplified.sharp = true;
        simplified.maxError = so.voxelSize / 4.0;
        report("plain marching cubes", calls, [&] { return volume::meshSurface(*grid, in.scene.root, plain); });
        report("--sharp", calls, [&] { return volume::meshSurface(*grid, in.scene.root, sharp); });
        report("--sharp --max-error voxel/4", 1, [&] { return volume::meshSurface(*grid, in.scene.root, simplified); });
        for (double adaptivity : {0.0, 0.5}) {
            const std::string name = "volumeToMesh, adaptivity " + std::string(adaptivity > 0 ? "0.5" : "0");
            report(name.c_str(), calls, [&] {
                std::vector<openvdb::Vec3s> points;
                std::vector<openvdb::Vec3I> tris;
                std::vector<openvdb::Vec4I> quads;
                openvdb::tools::volumeToMesh(*grid, points, tris, quads, 0.0, adaptivity);
                return fromOpenVdb(points, tris, quads);
            });
        }
    }
    return 0;
}
