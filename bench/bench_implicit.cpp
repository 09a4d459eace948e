// Implicit fields, side by side:
//  1. sampling a sphere into a narrow-band level set: isoforge's volume::sample (top-down, bounds)
//     vs openvdb::tools::createLevelSetSphere vs dense evaluation of every voxel of the box, at
//     resolutions 128..1024: time, points evaluated, and the growth per doubling;
//  2. a .vm model of ~8,000 statements: the 1024x1024 sign slice (tape pruning) vs a numpy
//     interpreter (bench/vm_numpy.py), and raw batch throughput of the whole tape.
// Usage: bench_implicit [--quick] [model.vm]
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

#include <openvdb/tools/LevelSetSphere.h>
#include <tbb/parallel_for.h>

#include "bench_util.h"
#include "implicit/primitives.h"
#include "implicit/tape.h"
#include "render/slice.h"
#include "volume/sample.h"
#include "volume/vdb_io.h"

using namespace isoforge;

int main(int argc, char** argv) {
    bench::checkArguments(argc, argv, "Usage: bench_implicit [--quick] [model.vm]", {"--quick"}, {}, true);
    volume::initializeOpenVdb();
    bool quick = false;
    std::string model = std::string(ISOFORGE_SOURCE_DIR) + "/data/text.vm";
    for (int i = 1; i < argc; ++i) {
        if (std::strcmp(argv[i], "--quick") == 0)
            quick = true;
        else
            model = argv[i];
    }
    const int reps = quick ? 3 : 5;

    std::printf("1. level-set sphere r = 1, half-width 3 voxels; median of %d (min - max), seconds\n", reps);
    std::printf("%6s %22s %22s %14s %14s %12s %10s\n", "N", "isoforge sample", "createLevelSetSphere", "vs LSSphere",
                "points", "dense pts", "dense s");
    const auto sphere = implicit::makeSphere(1.f);
    double lastTime = 0, lastPoints = 0;
    for (int n : quick ? std::vector<int>{128, 256} : std::vector<int>{128, 256, 512, 1024}) {
        const float voxel = 2.f / n;
        bench::Samples ours, theirs;
        volume::SampleStats st;
        for (int r = 0; r < reps; ++r) {
            volume::SampleOptions o;
            o.voxelSize = voxel;
            ours.seconds.push_back(bench::timed([&] { volume::sample(sphere, o, &st); }).first);
            theirs.seconds.push_back(bench::timed([&] {
                                         openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(
                                             1.f, openvdb::Vec3f(0.f), voxel, 3.f);
                                     }).first);
        }
        // Dense: every voxel centre of the box [-1 - band, 1 + band]^3, evaluated in batches.
        double denseSeconds = 0;
        const long long m = n + 8;
        const long long densePoints = m * m * m;
        if (n <= 256) {
            denseSeconds = bench::timed([&] {
                               tbb::parallel_for(0LL, m, [&](long long i) {
                                   std::vector<glm::vec3> p(static_cast<std::size_t>(m * m));
                                   std::vector<float> v(p.size());
                                   for (long long j = 0; j < m; ++j)
                                       for (long long k = 0; k < m; ++k)
                                           p[static_cast<std::size_t>(j * m + k)] =
                                               glm::vec3(i - m / 2, j - m / 2, k - m / 2) * voxel;
                                   sphere->values(p, v);
                               });
                           }).first;
        }
        std::printf("%6d %9.4f (%5.3f-%5.3f) %9.4f (%5.3f-%5.3f) %13.2fx %14llu %12lld %10s\n", n, ours.median(),
                    ours.min(), ours.max(), theirs.median(), theirs.min(), theirs.max(),
                    theirs.median() / ours.median(), static_cast<unsigned long long>(st.pointsEvaluated), densePoints,
                    n <= 256 ? std::to_string(denseSeconds).substr(0, 6).c_str() : "-");
        if (lastTime > 0)
            std::printf("       doubling N: time x%.2f, points x%.2f (a dense sampler: x8)\n", ours.median() / lastTime,
                        st.pointsEvaluated / lastPoints);
        lastTime = ours.median();
        lastPoints = static_cast<double>(st.pointsEvaluated);
    }

    std::printf("\n2. %s\n", model.c_str());
    const auto tape = implicit::readVmFile(model);
    const auto field = implicit::makeTapeField(tape, implicit::Box3::everything(), "model");
    render::SliceOptions so;
    so.size = 1024;
    so.sign = true;
    bench::Samples slice;
    render::SliceStats ss;
    for (int r = 0; r < reps; ++r)
        slice.seconds.push_back(bench::timed([&] { render::sliceField(field, so, &ss); }).first);
    std::printf("   %zu statements, %zu registers\n", tape->size(), tape->registers());
    std::printf("   sign slice 1024x1024 (quadtree + tape pruning): %.4f s median (%.4f-%.4f), %llu points evaluated\n",
                slice.median(), slice.min(), slice.max(), static_cast<unsigned long long>(ss.pointsEvaluated));
    // Raw throughput: the whole tape on 1M points, no pruning.
    std::vector<glm::vec3> pts(1 << 20);
    for (std::size_t i = 0; i < pts.size(); ++i)
        pts[i] = glm::vec3((i % 1024) / 512.f - 1.f, (i / 1024) / 512.f - 1.f, 0.f);
    std::vector<float> vals(pts.size());
    const double raw = bench::timed([&] {
                           tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pts.size(), 4096), [&](const auto& r) {
                               field->values(std::span<const glm::vec3>(pts.data() + r.begin(), r.size()),
                                             std::span<float>(vals.data() + r.begin(), r.size()));
                           });
                       }).first;
    std::printf("   whole tape on 1,048,576 points: %.3f s = %.1f M points/s, %.2f G statement evaluations/s\n", raw,
                pts.size() / raw / 1e6, pts.size() * double(tape->size()) / raw / 1e9);
    const std::string cmd =
        "/usr/bin/python3 " + std::string(ISOFORGE_SOURCE_DIR) + "/bench/vm_numpy.py " + model + " 1024 2>&1";
    if (FILE* p = popen(cmd.c_str(), "r")) {
        char buf[256] = {};
        const bool got = std::fgets(buf, sizeof buf, p) != nullptr;
        const int rc = pclose(p);
        double numpySeconds = 0;
        if (got && rc == 0 && std::sscanf(buf, "%lf", &numpySeconds) == 1)
            std::printf(
                "   numpy interpreter, same slice: %.3f s -> isoforge is %.0fx faster (%.0fx without pruning)\n",
                numpySeconds, numpySeconds / slice.median(), numpySeconds / raw);
        else
            std::printf("   numpy baseline unavailable (apt-get install python3-numpy): %s", buf);
    }
    return 0;
}
