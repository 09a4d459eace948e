// Primary-ray throughput at 1024x1024, 1 and 2 threads, side by side on one surface:
//   Embree path (a ~1M-triangle mesh of the sphere, shaded, one light, hard shadows),
//   direct grid marcher (the level set itself), direct field marcher (the analytic sphere),
//   OpenVDB's LevelSetRayIntersector driven over the same image and camera (hits and normals only),
//   and vdb_render as a whole process (read, render, write; -shader diffuse).
// Usage: bench_render [--quick]
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/RayIntersector.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "bench_util.h"
#include "implicit/primitives.h"
#include "render/embree_renderer.h"
#include "render/grid_march.h"
#include "render/ray_march.h"
#include "render/shading.h"
#include "volume/marching_cubes.h"
#include "volume/vdb_io.h"

using namespace isoforge;

int main(int argc, char** argv) {
    volume::initializeOpenVdb();
    const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
    const int size = quick ? 512 : 1024;
    const float radius = 10.f, voxel = 0.05f;  // 200 voxels of radius: about a million triangles
    auto grid = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(radius, openvdb::Vec3f(0.f), voxel, 3.f);
    volume::MeshingOptions mo;
    mo.normals = true;
    const mesh::TriMesh m = volume::extractIsosurface(*grid, mo);
    const auto sphere = implicit::makeSphere(radius);

    render::Look look;
    look.camera.eye = glm::vec3(0.f, -32.f, 8.f);
    look.camera.target = glm::vec3(0.f);
    look.camera.fov = 45.f;
    look.lights = {render::Light{false, glm::vec3(-1.f, 1.f, -1.5f), glm::vec3(1.f), 1.f}};
    render::RenderOptions opt;
    opt.width = opt.height = size;
    const double rays = double(size) * size;
    std::printf("%dx%d primary rays, sphere of radius %g (%g voxels), mesh of %zu triangles; Mrays/s (median of 3)\n",
                size, size, radius, radius / voxel, m.triangleCount());
    std::printf("%-46s %10s %10s\n", "", "1 thread", "2 threads");

    double mr[6][2] = {};
    for (int threads : {1, 2}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        const int ti = threads - 1;
        auto rate = [&](auto&& run) {
            bench::Samples s;
            for (int k = 0; k < 3; ++k) s.seconds.push_back(run());
            return rays / s.median() / 1e6;
        };
        // Embree, shaded with shadows (BVH build excluded; reported below).
        double build = 0;
        mr[0][ti] = rate([&] {
            render::RenderStats st;
            render::renderMeshes({{&m, {}, false}}, look, opt, &st);
            build = st.setupSeconds;
            return st.seconds - st.setupSeconds;
        });
        render::RenderOptions noShadow = opt;
        noShadow.shadows = false;
        mr[1][ti] = rate([&] {
            render::RenderStats st;
            render::renderMeshes({{&m, {}, false}}, look, noShadow, &st);
            return st.seconds - st.setupSeconds;
        });
        mr[2][ti] = rate([&] {
            render::RenderStats st;
            render::marchGrid(*grid, {render::IsoLayer{}}, true, look, noShadow, &st);
            return st.seconds;
        });
        mr[3][ti] = rate([&] {
            render::RenderStats st;
            render::marchField(sphere, implicit::Box3{glm::vec3(-radius - 1), glm::vec3(radius + 1)}, look, noShadow,
                               &st);
            return st.seconds;
        });
        // OpenVDB's LevelSetRayIntersector over the same camera rays (world-space hits and normals).
        mr[4][ti] = rate([&] {
            const double t0 = bench::now();
            const render::detail::RayGenerator gen(look.camera, size, size);
            using Inter = openvdb::tools::LevelSetRayIntersector<openvdb::FloatGrid>;
            const Inter master(*grid);
            tbb::enumerable_thread_specific<Inter> inters(master);
            std::vector<float> depth(static_cast<std::size_t>(size) * size);
            tbb::parallel_for(0, size, [&](int y) {
                Inter& in = inters.local();
                for (int x = 0; x < size; ++x) {
                    const auto r = gen(x + 0.5f, y + 0.5f);
                    const openvdb::math::Ray<double> ray(openvdb::Vec3d(r.origin.x, r.origin.y, r.origin.z),
                                                         openvdb::Vec3d(r.dir.x, r.dir.y, r.dir.z));
                    openvdb::Vec3d xyz, n;
                    depth[static_cast<std::size_t>(y) * size + x] =
                        in.intersectsWS(ray, xyz, n) ? float((xyz - ray.eye()).length()) : -1.f;
                }
            });
            return bench::now() - t0;
        });
        // vdb_render, the whole process.
        const auto tmp = std::filesystem::temp_directory_path() / "isoforge_bench_render";
        std::filesystem::create_directories(tmp);
        volume::writeVdb(tmp / "sphere.vdb", {grid});
        char cmd[1024];
        std::snprintf(cmd, sizeof cmd,
                      "vdb_render %s %s -res %dx%d -translate 0,-32,8 -lookat 0,0,0 -up 0,0,1 -fov 45 -cpus %d "
                      "-shader diffuse >/dev/null 2>&1",
                      (tmp / "sphere.vdb").c_str(), (tmp / "out.exr").c_str(), size, size, threads);
        mr[5][ti] = rate([&] {
            const double t0 = bench::now();
            if (std::system(cmd) != 0) return 1e30;
            return bench::now() - t0;
        });
        if (threads == 2)
            std::printf("(Embree BVH build for %zu triangles: %.3f s, not counted)\n", m.triangleCount(), build);
    }
    const char* names[6] = {"Embree, shaded + shadows",          "Embree, shaded, no shadows",
                            "isoforge grid marcher (level set)", "isoforge field marcher (analytic sphere)",
                            "OpenVDB LevelSetRayIntersector",    "vdb_render (whole process)"};
    for (int i = 0; i < 6; ++i) std::printf("%-46s %10.2f %10.2f\n", names[i], mr[i][0], mr[i][1]);
    std::printf(
        "ratios at 2 threads: grid marcher / LevelSetRayIntersector = %.2fx, grid marcher / vdb_render = %.2fx,"
        " Embree+shadows / LevelSetRayIntersector = %.2fx\n",
        mr[2][1] / mr[4][1], mr[2][1] / mr[5][1], mr[0][1] / mr[4][1]);
    std::printf("1 -> 2 threads: Embree %.2fx, grid marcher %.2fx, field marcher %.2fx\n", mr[0][1] / mr[0][0],
                mr[2][1] / mr[2][0], mr[3][1] / mr[3][0]);
    return 0;
}
