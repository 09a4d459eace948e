// Marching cubes, side by side on the same grids and thread counts:
//   isoforge    volume::extractIsosurface (output buffers reused between runs)
//   volumeToMesh openvdb::tools::volumeToMesh, adaptivity 0 (quads counted as two triangles)
//   floor       one parallel pass that reads every active voxel once (the memory floor)
// Usage: bench_marching_cubes [--quick] [smoke.vdb]
#include <atomic>
#include <cstring>
#include <tuple>

#include <malloc.h>

#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "bench_util.h"
#include "volume/marching_cubes.h"
#include "volume/vdb_io.h"

using namespace isoforge;

namespace {

struct Input {
    std::string name;
    openvdb::FloatGrid::Ptr grid;
    float iso;
};

double readFloor(const openvdb::FloatGrid& grid) {
    std::vector<const openvdb::FloatTree::LeafNodeType*> leaves;
    grid.tree().getNodes(leaves);
    return tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, leaves.size(), 64), 0.0,
        [&](const tbb::blocked_range<std::size_t>& r, double acc) {
            for (std::size_t i = r.begin(); i != r.end(); ++i)
                for (auto it = leaves[i]->cbeginValueOn(); it; ++it) acc += *it;
            return acc;
        },
        std::plus<double>());
}

}  // namespace

int main(int argc, char** argv) {
    bench::checkArguments(argc, argv, "Usage: bench_marching_cubes [--quick] [smoke.vdb]", {"--quick"}, {}, true);
    volume::initializeOpenVdb();
    bool quick = false;
    std::string smokePath = std::string(ISOFORGE_SHARED_DATA) + "/volumes/openvdb-samples/smoke.vdb";
    for (int i = 1; i < argc; ++i) {
        if (std::strcmp(argv[i], "--quick") == 0)
            quick = true;
        else
            smokePath = argv[i];
    }

    std::vector<Input> inputs;
    for (float r : quick ? std::vector<float>{100.f} : std::vector<float>{100.f, 200.f, 400.f}) {
        auto g = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(r, openvdb::Vec3f(0.f), 1.f, 3.f);
        inputs.push_back({"sphere r=" + std::to_string(static_cast<int>(r)), g, 0.f});
    }
    try {
        inputs.push_back({"smoke iso 0.2", volume::readFloatGrid(smokePath, std::string("density")), 0.2f});
    } catch (const std::exception& e) {
        std::fprintf(stderr, "skipping smoke: %s\n", e.what());
    }

    // Memory: one cold call each, after returning freed memory to the system, output included.
    std::printf(
        "one cold call each (fresh output, all threads): peak resident memory and time\n%-15s %12s %14s %11s %14s\n",
        "input", "isoforge MiB", "volToMesh MiB", "isoforge s", "volToMesh s");
    for (const Input& in : inputs) {
        malloc_trim(0);
        long long oursPeak = 0, vtmPeak = 0;
        double oursTime = 0, vtmTime = 0;
        {
            mesh::TriMesh fresh;
            volume::MeshingOptions opt;
            opt.isovalue = in.iso;
            std::tie(oursTime, oursPeak) = bench::timed([&] { volume::extractIsosurface(*in.grid, opt, fresh); });
        }
        malloc_trim(0);
        {
            std::vector<openvdb::Vec3s> points;
            std::vector<openvdb::Vec3I> tris;
            std::vector<openvdb::Vec4I> quads;
            std::tie(vtmTime, vtmPeak) =
                bench::timed([&] { openvdb::tools::volumeToMesh(*in.grid, points, tris, quads, in.iso, 0.0); });
        }
        std::printf("%-15s %12.1f %14.1f %11.4f %14.4f\n", in.name.c_str(), oursPeak / 1048576.0, vtmPeak / 1048576.0,
                    oursTime, vtmTime);
    }
    std::printf("\n%-15s %3s %-13s %10s %19s %11s %9s %8s %8s\n", "input", "thr", "method", "median s", "(min - max)",
                "triangles", "Mtri/s", "vs vtm", "vs floor");
    for (const Input& in : inputs) {
        double ours1 = 0;
        for (int threads : {1, 2}) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
            const int reps = quick ? 3 : (in.grid->activeVoxelCount() > 5'000'000 ? 5 : 9);
            bench::Samples ours, vtm, floor;
            std::size_t oursTris = 0, vtmTris = 0;
            mesh::TriMesh out;  // reused: the realistic steady state of a caller meshing repeatedly
            volume::MeshingOptions opt;
            opt.isovalue = in.iso;
            volatile double sink = 0;
            for (int rep = 0; rep < reps; ++rep) {
                ours.seconds.push_back(bench::timed([&] { volume::extractIsosurface(*in.grid, opt, out); }).first);
                oursTris = out.triangles.size();

                std::vector<openvdb::Vec3s> points;
                std::vector<openvdb::Vec3I> tris;
                std::vector<openvdb::Vec4I> quads;
                vtm.seconds.push_back(bench::timed([&] {
                                          openvdb::tools::volumeToMesh(*in.grid, points, tris, quads, in.iso, 0.0);
                                      }).first);
                vtmTris = tris.size() + 2 * quads.size();

                floor.seconds.push_back(bench::timed([&] { sink = sink + readFloor(*in.grid); }).first);
            }
            if (threads == 1) ours1 = ours.median();
            auto row = [&](const char* method, const bench::Samples& s, std::size_t tris) {
                std::printf("%-15s %3d %-13s %10.4f %8.4f - %8.4f %11zu %9.1f %8.2f %8.1f\n", in.name.c_str(), threads,
                            method, s.median(), s.min(), s.max(), tris, tris ? tris / s.median() / 1e6 : 0.0,
                            vtm.median() / s.median(), s.median() / floor.median());
            };
            row("isoforge", ours, oursTris);
            row("volumeToMesh", vtm, vtmTris);
            row("floor", floor, 0);
            if (threads == 2)
                std::printf("%-15s     isoforge speed-up 1 -> 2 threads: %.2fx\n", in.name.c_str(),
                            ours1 / ours.median());
        }
    }
    std::printf(
        "vs vtm: volumeToMesh time / this time (higher is faster). vs floor: this time / floor time.\n"
        "isoforge reuses its output mesh between runs (resize, no reallocation); volumeToMesh allocates anew.\n");
    return 0;
}
