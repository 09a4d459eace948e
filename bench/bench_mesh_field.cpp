// Meshes into level sets, side by side: isoforge's exact-distance mesh field (BVH distance, sign by
// pseudonormals for generated closed meshes or by the hierarchical winding number for files), sampled by
// volume::sample into a narrow band, against OpenVDB's tools::meshToLevelSet (what `isoforge voxelize`
// uses) on the same mesh, voxel size and band. Also reports how far the two grids' values differ on
// the voxels both hold, in voxels.
// Usage: bench_mesh_field [--quick]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include <glm/common.hpp>

#include "bench_util.h"
#include "csg/shapes.h"
#include "mesh/io.h"
#include "mesh/parametric.h"
#include "volume/sample.h"
#include "volume/vdb_io.h"
#include "volume/voxelize.h"

using namespace isoforge;

int main(int argc, char** argv) {
    bench::checkArguments(argc, argv, "Usage: bench_mesh_field [--quick]", {"--quick"});
    volume::initializeOpenVdb();
    const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
    const std::filesystem::path shared = ISOFORGE_SHARED_DATA;
    struct Input {
        const char* name;
        mesh::TriMesh mesh;
        bool generated;
    };
    std::vector<Input> inputs;
    inputs.push_back(
        {"cow (file)", mesh::readMesh(std::filesystem::path(ISOFORGE_SOURCE_DIR) / "data/cow.obj"), false});
    if (!quick) {
        inputs.push_back({"vase (file)", mesh::readMesh(shared / "meshes/vase/Vase.stl"), false});
        inputs.push_back({"NURBS torus (generated)", mesh::tessellate(mesh::nurbsTorus(2.0, 0.6), 128), true});
    }
    const int resolution = quick ? 128 : 256;
    std::printf("narrow band of 3 voxels each side, %d voxels along the longest side; seconds\n", resolution);
    std::printf("%-24s %9s %10s %12s %12s %10s %14s %12s\n", "mesh", "triangles", "isoforge", "OpenVDB m2ls", "ratio",
                "voxels", "|diff| median", "sign differs");
    for (const Input& in : inputs) {
        const mesh::Bounds b = mesh::bounds(in.mesh);
        const glm::vec3 size = b.max - b.min;
        const float voxel = std::max(size.x, std::max(size.y, size.z)) / float(resolution);
        std::vector<glm::vec3> pts = in.mesh.positions;
        std::vector<glm::uvec3> tris = in.mesh.triangles;
        const auto field = csg::makeTriangleMeshField(pts, tris, "mesh", nullptr, in.generated);
        volume::SampleOptions o;
        o.voxelSize = voxel;
        openvdb::FloatGrid::Ptr ours, theirs;
        bench::Samples a, v;
        for (int rep = 0; rep < 3; ++rep) {  // alternate the contenders
            a.seconds.push_back(bench::timed([&] { ours = volume::sample(field, o); }).first);
            volume::VoxelizeOptions vo;
            vo.voxelSize = voxel;
            v.seconds.push_back(bench::timed([&] { theirs = volume::voxelize(in.mesh, vo).grid; }).first);
        }
        // Agreement on the voxels both hold (both grids are index-aligned: same voxel size, origin 0).
        std::vector<float> diffs;
        std::size_t signs = 0;  // voxels at least half a voxel from the surface whose sign differs
        auto acc = theirs->getConstAccessor();
        for (auto it = ours->cbeginValueOn(); it; ++it) {
            float w;
            if (!acc.probeValue(it.getCoord(), w)) continue;
            diffs.push_back(std::abs(*it - w) / voxel);
            signs += (*it < 0) != (w < 0) && std::abs(w) > 0.5f * voxel;
        }
        std::nth_element(diffs.begin(), diffs.begin() + std::ptrdiff_t(diffs.size() / 2), diffs.end());
        std::printf("%-24s %9zu %10.3f %12.3f %11.2fx %10llu %14.3f %12zu\n", in.name, in.mesh.triangleCount(),
                    a.median(), v.median(), v.median() / a.median(),
                    static_cast<unsigned long long>(ours->activeVoxelCount()),
                    diffs.empty() ? -1.0 : double(diffs[diffs.size() / 2]), signs);
    }
    std::printf("ratio > 1: isoforge faster\n");
    return 0;
}
