// The OpenVDB anchor of bench/scaling.py: a whole command's worth of OpenVDB's own way to mesh a big
// sphere, tools::createLevelSetSphere then tools::volumeToMesh (held in memory, as OpenVDB holds them),
// with the time of each and the peak resident memory. Usage: openvdb_sphere_mesh RADIUS_VOXELS
#include <chrono>
#include <cstdio>
#include <cstdlib>

#include <openvdb/openvdb.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <sys/resource.h>

int main(int argc, char** argv) {
    if (argc != 2 || std::atof(argv[1]) <= 0) {
        std::fprintf(stderr, "Usage: openvdb_sphere_mesh RADIUS_VOXELS\n");
        return 2;
    }
    openvdb::initialize();
    const float radius = static_cast<float>(std::atof(argv[1]));
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    // Radius 1 at a voxel of 1 / radius: the same voxels as `isoforge mesh --shape "sphere(r=1)" --voxel 1/R`.
    auto grid = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(1.f, openvdb::Vec3f(0.f), 1.f / radius, 3.f);
    const auto t1 = Clock::now();
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> triangles;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(*grid, points, triangles, quads, 0.0, 0.0);
    const auto t2 = Clock::now();
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    std::printf(
        "openvdb radius %.0f: %zu points, %zu triangles + %zu quads; sphere %.3f s, volumeToMesh %.3f s, peak %ld "
        "MiB\n",
        radius, points.size(), triangles.size(), quads.size(), std::chrono::duration<double>(t1 - t0).count(),
        std::chrono::duration<double>(t2 - t1).count(), u.ru_maxrss / 1024);
    return 0;
}
