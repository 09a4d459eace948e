// CSG sampling, side by side: a union of N random spheres and boxes (N = 1,000 and 10,000) and a deep
// difference chain, sampled by volume::sample with CSG pruning, without it (simplify disabled), and
// through OpenVDB's own level-set CSG (createLevelSetSphere per sphere, csgUnion) as the anchor, like
// for like on the spheres of each scene (OpenVDB has no rounded/arbitrary boxes to match the rest).
// Usage: bench_csg [--quick]
#include <cstdio>
#include <cstring>
#include <random>

#include <openvdb/tools/Composite.h>
#include <openvdb/tools/LevelSetSphere.h>

#include "bench_util.h"
#include "csg/nodes.h"
#include "implicit/primitives.h"
#include "volume/sample.h"
#include "volume/vdb_io.h"

using namespace isoforge;

namespace {

/// Forwards everything but simplify(): the tree is evaluated whole everywhere.
class NoPruning final : public implicit::Field {
public:
    explicit NoPruning(implicit::FieldPtr f) : f_(std::move(f)) {}
    float value(const glm::vec3& p) const override { return f_->value(p); }
    void values(std::span<const glm::vec3> p, std::span<float> o) const override { f_->values(p, o); }
    implicit::Interval bound(const implicit::Box3& b) const override { return f_->bound(b); }
    implicit::Box3 bounds() const override { return f_->bounds(); }
    bool isDistance() const override { return f_->isDistance(); }
    std::string describe() const override { return f_->describe(); }

private:
    implicit::FieldPtr f_;
};

struct Sphere {
    glm::vec3 c;
    float r;
};

}  // namespace

int main(int argc, char** argv) {
    bench::checkArguments(argc, argv, "Usage: bench_csg [--quick]", {"--quick"});
    volume::initializeOpenVdb();
    const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
    const float voxel = 0.004f;
    std::printf("voxel %g, unit cube scene; seconds (points evaluated)\n", voxel);
    std::printf("%-22s %24s %24s %14s %10s\n", "scene", "pruned", "not pruned", "OpenVDB csg", "speed-up");
    for (int n : quick ? std::vector<int>{1000} : std::vector<int>{1000, 10000}) {
        std::mt19937 rng(42);
        std::uniform_real_distribution<float> u(0.05f, 0.95f);
        const float r = 0.35f / std::cbrt(static_cast<float>(n));
        std::vector<implicit::FieldPtr> kids;
        std::vector<Sphere> spheres;
        for (int i = 0; i < n; ++i) {
            const glm::vec3 c(u(rng), u(rng), u(rng));
            if (i % 2) {
                kids.push_back(implicit::makeTranslated(implicit::makeSphere(r), c));
                spheres.push_back({c, r});
            } else {
                kids.push_back(implicit::makeTranslated(implicit::makeBox(glm::vec3(1.4f * r)), c));
            }
        }
        auto scene = csg::makeUnion(kids);
        volume::SampleOptions o;
        o.voxelSize = voxel;
        volume::SampleStats a, b;
        const double tp = bench::timed([&] { volume::sample(scene, o, &a); }).first;
        double tn = -1;
        if (n <= 1000) tn = bench::timed([&] { volume::sample(std::make_shared<NoPruning>(scene), o, &b); }).first;
        // OpenVDB anchor: the spheres only (it has no box of arbitrary size here), unioned pairwise.
        const double tv =
            bench::timed([&] {
                auto acc = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(
                    spheres[0].r, openvdb::Vec3f(spheres[0].c.x, spheres[0].c.y, spheres[0].c.z), voxel);
                for (std::size_t i = 1; i < spheres.size(); ++i) {
                    auto g = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(
                        spheres[i].r, openvdb::Vec3f(spheres[i].c.x, spheres[i].c.y, spheres[i].c.z), voxel);
                    openvdb::tools::csgUnion(*acc, *g);
                }
            }).first;
        // Like for like: the same spheres alone, through isoforge and through OpenVDB.
        std::vector<implicit::FieldPtr> sphereKids;
        for (const Sphere& s : spheres) sphereKids.push_back(implicit::makeTranslated(implicit::makeSphere(s.r), s.c));
        volume::SampleStats c;
        const double ts = bench::timed([&] { volume::sample(csg::makeUnion(sphereKids), o, &c); }).first;
        char pruned[64], unpruned[64], spheresOnly[64];
        std::snprintf(pruned, sizeof pruned, "%.3f (%llu)", tp, static_cast<unsigned long long>(a.pointsEvaluated));
        if (tn >= 0)
            std::snprintf(unpruned, sizeof unpruned, "%.3f (%llu)", tn,
                          static_cast<unsigned long long>(b.pointsEvaluated));
        else
            std::snprintf(unpruned, sizeof unpruned, "skipped (~15 min)");
        std::snprintf(spheresOnly, sizeof spheresOnly, "%.3f (%llu)", ts,
                      static_cast<unsigned long long>(c.pointsEvaluated));
        std::printf("union of %-13d %24s %24s %14s %9s\n", n, pruned, unpruned, "-",
                    tn >= 0 ? (std::to_string(tn / tp).substr(0, 5) + "x").c_str() : "-");
        std::printf("  its %-5zu spheres only %24s %24s %14.3f %8.2fx  (OpenVDB / isoforge)\n", spheres.size(),
                    spheresOnly, "-", tv, tv / ts);
    }
    // A deep difference chain: ((box - s1) - s2) - ... nested 200 deep.
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.1f, 0.9f);
    implicit::FieldPtr chain = implicit::makeTranslated(implicit::makeBox(glm::vec3(0.9f)), glm::vec3(0.5f));
    for (int i = 0; i < 200; ++i)
        chain = csg::makeDifference(
            {chain, implicit::makeTranslated(implicit::makeSphere(0.03f), glm::vec3(u(rng), u(rng), u(rng)))});
    volume::SampleOptions o;
    o.voxelSize = voxel;
    volume::SampleStats a, b;
    const double tp = bench::timed([&] { volume::sample(chain, o, &a); }).first;
    const double tn = bench::timed([&] { volume::sample(std::make_shared<NoPruning>(chain), o, &b); }).first;
    std::printf("difference chain 200   %9.3f (%llu) %9.3f (%llu) %14s %8.1fx\n", tp,
                static_cast<unsigned long long>(a.pointsEvaluated), tn,
                static_cast<unsigned long long>(b.pointsEvaluated), "-", tn / tp);
    return 0;
}
