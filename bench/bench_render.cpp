// Primary-ray throughput at 1024x1024, 1 and 2 threads, side by side on one surface:
//   Embree path (a ~1M-triangle mesh of the sphere, shaded, one light, hard shadows), and Embree's
//   packets alone on the same rays (primary and shadow packets, no shading: what the shaded path
//   would reach if shading cost nothing; also measured in 7 alternating pairs of frames; and the
//   primary packets alone, the "bare rtcIntersect16"),
//   direct grid marcher (the level set itself: per frame on a PreparedGrid, and as one call that
//   prepares too), direct field marcher (the analytic sphere),
//   OpenVDB's LevelSetRayIntersector driven over the same image and camera (hits and normals only),
//   and vdb_render as a whole process (read, render, write; -shader diffuse).
// The grid marcher / intersector ratio is also measured in 7 alternating pairs of frames per thread
// count (both then see the same state of a machine whose speed drifts).
// Usage: bench_render [--quick] [--only N] [--threads T]   (for profiling: row N = 0..8 alone, T threads alone)
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>

#include <embree3/rtcore.h>
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
    bench::checkArguments(argc, argv,
                          "Usage: bench_render [--quick] [--only N] [--threads T]\n  --quick    512x512 instead of "
                          "1024x1024\n  --only N   row N (0..8) alone, for profiling\n  --threads T  T threads alone",
                          {"--quick"}, {"--only", "--threads"});
    volume::initializeOpenVdb();
    bool quick = false;
    int only = -1, onlyThreads = 0;
    for (int i = 1; i < argc; ++i) {
        if (std::strcmp(argv[i], "--quick") == 0) quick = true;
        if (std::strcmp(argv[i], "--only") == 0 && i + 1 < argc) only = std::atoi(argv[++i]);
        if (std::strcmp(argv[i], "--threads") == 0 && i + 1 < argc) onlyThreads = std::atoi(argv[++i]);
    }
    const int size = quick ? 512 : 1024;
    const float radius = 10.f, voxel = 0.0625f;  // 160 voxels of radius: a mesh of 0.97 M triangles
    auto grid = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(radius, openvdb::Vec3f(0.f), voxel, 3.f);
    volume::MeshingOptions mo;
    mo.normals = true;
    // The mesh is only needed by the Embree rows (skipped when profiling another one).
    const mesh::TriMesh m = only <= 1 || only >= 7 ? volume::extractIsosurface(*grid, mo) : mesh::TriMesh{};
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
    std::printf("%-48s %10s %10s\n", "", "1 thread", "2 threads");

    double mr[9][2] = {};
    double pairedRatio[2][3] = {};    // median, lowest, highest of 7 pairs
    double pairedShading[2][3] = {};  // shaded Embree frame time / bare packets frame time, 7 pairs
    // Embree's packets alone: the renderer's 4x4 blocks, primary packets, then a shadow packet of the
    // lanes facing the light, started as far off the surface as the renderer starts them.
    RTCDevice device = only <= 1 || only >= 7 ? rtcNewDevice(nullptr) : nullptr;
    RTCScene bare = nullptr;
    float lift = 0.f;
    if (device) {
        bare = rtcNewScene(device);
        rtcSetSceneBuildQuality(bare, RTC_BUILD_QUALITY_HIGH);
        rtcSetSceneFlags(bare, RTC_SCENE_FLAG_ROBUST);
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        std::memcpy(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, m.positions.size()),
                    m.positions.data(), 12 * m.positions.size());
        std::memcpy(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, m.triangles.size()),
                    m.triangles.data(), 12 * m.triangles.size());
        rtcCommitGeometry(g);
        rtcAttachGeometry(bare, g);
        rtcReleaseGeometry(g);
        rtcCommitScene(bare);
        double edges = 0;
        for (const auto& t : m.triangles)
            edges += double(glm::length(m.positions[t.y] - m.positions[t.x])) +
                     glm::length(m.positions[t.z] - m.positions[t.y]) +
                     glm::length(m.positions[t.x] - m.positions[t.z]);
        lift = float(0.25 * edges / (3.0 * double(m.triangles.size())));
    }
    auto bareFrame = [&](bool shadows) {
        const double t0 = bench::now();
        const render::detail::RayGenerator gen(look.camera, size, size);
        const glm::vec3 L = -glm::normalize(look.lights[0].vector);
        tbb::parallel_for(tbb::blocked_range<int>(0, (size / 16) * (size / 16), 1), [&](const auto& r) {
            for (int tile = r.begin(); tile != r.end(); ++tile) {
                const int tx = (tile % (size / 16)) * 16, ty = (tile / (size / 16)) * 16;
                for (int by = ty; by < ty + 16; by += 4)
                    for (int bx = tx; bx < tx + 16; bx += 4) {
                        float xs[16], ys[16];
                        for (int k = 0; k < 16; ++k)
                            xs[k] = float(bx + (k & 3)) + 0.5f, ys[k] = float(by + (k >> 2)) + 0.5f;
                        render::detail::RayBlock b;
                        gen.block(xs, ys, b);
                        alignas(64) int valid[16];
                        alignas(64) RTCRayHit16 rh;
                        std::memcpy(rh.ray.org_x, b.ox, 64), std::memcpy(rh.ray.org_y, b.oy, 64);
                        std::memcpy(rh.ray.org_z, b.oz, 64), std::memcpy(rh.ray.dir_x, b.dx, 64);
                        std::memcpy(rh.ray.dir_y, b.dy, 64), std::memcpy(rh.ray.dir_z, b.dz, 64);
                        for (int k = 0; k < 16; ++k) {
                            valid[k] = -1;
                            rh.ray.tnear[k] = 0.f, rh.ray.tfar[k] = std::numeric_limits<float>::infinity();
                            rh.ray.mask[k] = ~0u, rh.ray.flags[k] = 0, rh.ray.time[k] = 0.f;
                            rh.hit.geomID[k] = rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
                        }
                        RTCIntersectContext ctx;
                        rtcInitIntersectContext(&ctx);
                        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
                        rtcIntersect16(valid, bare, &ctx, &rh);
                        alignas(64) int sv[16];
                        alignas(64) RTCRay16 sr;
                        bool any = false;
                        for (int k = 0; k < 16; ++k) {
                            sv[k] = 0;
                            sr.tnear[k] = 0.f, sr.tfar[k] = std::numeric_limits<float>::infinity();
                            sr.mask[k] = ~0u, sr.flags[k] = 0, sr.time[k] = 0.f;
                            sr.dir_x[k] = L.x, sr.dir_y[k] = L.y, sr.dir_z[k] = L.z;
                            sr.org_x[k] = sr.org_y[k] = sr.org_z[k] = 0.f;
                            if (rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) continue;
                            const glm::vec3 n =
                                glm::normalize(glm::vec3(rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]));
                            if (glm::dot(n, L) <= 0.f) continue;
                            const float t = rh.ray.tfar[k];
                            sr.org_x[k] = b.ox[k] + t * b.dx[k] + n.x * lift;
                            sr.org_y[k] = b.oy[k] + t * b.dy[k] + n.y * lift;
                            sr.org_z[k] = b.oz[k] + t * b.dz[k] + n.z * lift;
                            sv[k] = -1;
                            any = true;
                        }
                        if (!any || !shadows) continue;
                        RTCIntersectContext sctx;
                        rtcInitIntersectContext(&sctx);
                        sctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
                        rtcOccluded16(sv, bare, &sctx, &sr);
                    }
            }
        });
        return bench::now() - t0;
    };
    for (int threads : {1, 2}) {
        if (onlyThreads > 0 && threads != onlyThreads) continue;
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        const int ti = threads - 1;
        int row = 0;
        auto rate = [&](auto&& run) {
            if (only >= 0 && row++ != only) return 0.0;
            bench::Samples s;
            for (int k = 0; k < 3; ++k) s.seconds.push_back(run());
            return rays / s.median() / 1e6;
        };
        // Embree, shaded with shadows, per frame: the scene (BVH) built once, reported below.
        double build = 0;
        std::unique_ptr<render::PreparedMeshes> scene;
        if (only < 0 || only <= 1) {
            scene = std::make_unique<render::PreparedMeshes>(std::vector<render::MeshObject>{{&m, {}, false}});
            build = scene->setupSeconds();
        }
        mr[0][ti] = rate([&] {
            render::RenderStats st;
            scene->render(look, opt, &st);
            return st.seconds;
        });
        render::RenderOptions noShadow = opt;
        noShadow.shadows = false;
        mr[1][ti] = rate([&] {
            render::RenderStats st;
            scene->render(look, noShadow, &st);
            return st.seconds;
        });
        row = 7;  // Embree's packets alone: printed after the shaded rows
        mr[7][ti] = rate([&] { return bareFrame(true); });
        row = 8;
        mr[8][ti] = rate([&] { return bareFrame(false); });
        if (only < 0) {
            std::vector<double> ratios;
            for (int k = 0; k < 7; ++k) {
                render::RenderStats st;
                scene->render(look, opt, &st);
                ratios.push_back(bareFrame(true) / st.seconds);
            }
            std::sort(ratios.begin(), ratios.end());
            pairedShading[ti][0] = ratios[3];
            pairedShading[ti][1] = ratios.front();
            pairedShading[ti][2] = ratios.back();
        }
        row = 2;
        // The grid marcher per frame: the grid prepared once (leaf table, crossed-cell boxes: like the
        // BVH, reported below), then the per-view depth pre-pass and the rays.
        double prepare = 0;
        mr[2][ti] = rate([&] {
            const double t0 = bench::now();
            const render::PreparedGrid prepared(*grid, {render::IsoLayer{}}, true);
            prepare = bench::now() - t0;
            render::RenderStats st;
            prepared.render(look, noShadow, &st);
            return st.seconds;
        });
        // ... and as one call (what `isoforge render sphere.vdb` does).
        mr[3][ti] = rate([&] {
            render::RenderStats st;
            render::marchGrid(*grid, {render::IsoLayer{}}, true, look, noShadow, &st);
            return st.seconds;
        });
        mr[4][ti] = rate([&] {
            render::RenderStats st;
            render::marchField(sphere, implicit::Box3{glm::vec3(-radius - 1), glm::vec3(radius + 1)}, look, noShadow,
                               &st);
            return st.seconds;
        });
        // OpenVDB's LevelSetRayIntersector over the same camera rays (world-space hits and normals).
        auto intersectorFrame = [&] {
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
        };
        mr[5][ti] = rate(intersectorFrame);
        // The ratio the target is about, measured in pairs (a grid-marcher frame, then an
        // intersector frame) so that both see the same state of a machine whose speed drifts.
        if (only < 0) {
            const render::PreparedGrid prepared(*grid, {render::IsoLayer{}}, true);
            std::vector<double> ratios;
            for (int k = 0; k < 7; ++k) {
                render::RenderStats st;
                prepared.render(look, noShadow, &st);
                ratios.push_back(intersectorFrame() / st.seconds);
            }
            std::sort(ratios.begin(), ratios.end());
            pairedRatio[ti][0] = ratios[3];
            pairedRatio[ti][1] = ratios.front();
            pairedRatio[ti][2] = ratios.back();
        }
        // vdb_render, the whole process.
        const auto tmp = std::filesystem::temp_directory_path() / "isoforge_bench_render";
        std::filesystem::create_directories(tmp);
        volume::writeVdb(tmp / "sphere.vdb", {grid});
        char cmd[1024];
        std::snprintf(cmd, sizeof cmd,
                      "vdb_render %s %s -res %dx%d -translate 0,-32,8 -lookat 0,0,0 -up 0,0,1 -fov 45 -cpus %d "
                      "-shader diffuse >/dev/null 2>&1",
                      (tmp / "sphere.vdb").c_str(), (tmp / "out.exr").c_str(), size, size, threads);
        mr[6][ti] = rate([&] {
            const double t0 = bench::now();
            if (std::system(cmd) != 0) return 1e30;
            return bench::now() - t0;
        });
        if (threads == 2 || onlyThreads == 1) {
            std::printf("(Embree BVH build for %zu triangles: %.3f s, not counted)\n", m.triangleCount(), build);
            std::printf(
                "(grid preparation, leaf table and crossed-cell boxes: %.3f s, not counted in the per-frame row)\n",
                prepare);
        }
    }
    const char* names[9] = {"Embree, shaded + shadows",
                            "Embree, shaded, no shadows",
                            "isoforge grid marcher, per frame (prepared)",
                            "isoforge grid marcher, one call (prepare+frame)",
                            "isoforge field marcher (analytic sphere)",
                            "OpenVDB LevelSetRayIntersector",
                            "vdb_render (whole process)",
                            "Embree packets alone (primary + shadow)",
                            "Embree packets alone (primary only)"};
    for (int i : {0, 7, 1, 8, 2, 3, 4, 5, 6}) std::printf("%-48s %10.2f %10.2f\n", names[i], mr[i][0], mr[i][1]);
    // Ratios only where every row ran at both thread counts (--only and --threads are for profiling).
    const bool full = only < 0 && onlyThreads == 0;
    if (full)
        for (int ti : {0, 1})
            std::printf(
                "ratios at %d thread%s: grid marcher / LevelSetRayIntersector = %.2fx per frame, %.2fx in one call;"
                " grid marcher / vdb_render = %.2fx; Embree+shadows / LevelSetRayIntersector = %.2fx\n",
                ti + 1, ti ? "s" : "", mr[2][ti] / mr[5][ti], mr[3][ti] / mr[5][ti], mr[3][ti] / mr[6][ti],
                mr[0][ti] / mr[5][ti]);
    if (full)
        for (int ti : {0, 1})
            std::printf(
                "paired at %d thread%s (7 pairs of frames, grid marcher then intersector): %.2fx median, "
                "%.2fx-%.2fx\n",
                ti + 1, ti ? "s" : "", pairedRatio[ti][0], pairedRatio[ti][1], pairedRatio[ti][2]);
    if (full)
        for (int ti : {0, 1})
            std::printf(
                "Embree shaded + shadows at %d thread%s, as a fraction of the packets alone (7 pairs of frames): "
                "%.2f median, %.2f-%.2f\n",
                ti + 1, ti ? "s" : "", pairedShading[ti][0], pairedShading[ti][1], pairedShading[ti][2]);
    if (bare) rtcReleaseScene(bare);
    if (device) rtcReleaseDevice(device);
    if (full)
        std::printf("1 -> 2 threads: Embree %.2fx, grid marcher %.2fx (per frame), field marcher %.2fx\n",
                    mr[0][1] / mr[0][0], mr[2][1] / mr[2][0], mr[4][1] / mr[4][0]);
    return 0;
}
