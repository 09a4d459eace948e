// Repair: flipped triangles, inside-out components, cavities, degenerate and duplicate triangles,
// and what cannot be fixed (a Moebius strip).
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "mesh/io.h"
#include "mesh/primitives.h"
#include "mesh/repair.h"
#include "test_util.h"

using namespace isoforge;

namespace {
void append(mesh::TriMesh& to, const mesh::TriMesh& m, float scale, bool inverted) {
    const auto base = static_cast<std::uint32_t>(to.positions.size());
    for (const auto& p : m.positions) to.positions.push_back(p * scale);
    for (const auto& t : m.triangles)
        to.triangles.push_back(inverted ? glm::uvec3(base + t.x, base + t.z, base + t.y) : t + base);
}
}  // namespace

TEST(Repair, FixesOrientationKeepsCavitiesAndDropsDegenerates) {
    // A hollow ball: an outer icosphere (turned inside out) around an inner one (a cavity, also
    // inside out: it must end facing inward), with random triangles flipped, plus junk.
    const mesh::TriMesh ico = mesh::makeIcosphere(3);
    mesh::TriMesh m;
    append(m, ico, 2.f, true);
    append(m, ico, 1.f, false);
    std::mt19937 rng(3);
    for (auto& t : m.triangles)
        if (rng() % 5 == 0) std::swap(t.y, t.z);
    m.triangles.push_back({0, 0, 1});        // repeated index
    m.triangles.push_back(m.triangles[10]);  // duplicate
    const double expected =
        4.0 / 3.0 * M_PI * (8.0 - 1.0) * mesh::signedVolume(ico) / (4.0 / 3.0 * M_PI * 0.125) * 0.125;
    const mesh::RepairReport r = mesh::repair(m);
    EXPECT_EQ(r.degenerateRemoved, 1u);
    EXPECT_EQ(r.duplicatesRemoved, 1u);
    EXPECT_GT(r.trianglesFlipped, 0u);
    EXPECT_EQ(r.nonOrientableComponents, 0u);
    const auto report = test::expectClosedSurface(m, "repaired hollow ball");
    EXPECT_EQ(report.components, 2u);
    EXPECT_NEAR(report.volume, expected, 1e-6 * expected) << "outer out, cavity in";

    // Real data: the cow, every other triangle flipped, comes back as it was (outward, closed).
    mesh::TriMesh cow = mesh::readMesh(test::sharedData() / "meshes/cow/cow.obj");
    const double cowVolume = mesh::signedVolume(cow);
    for (std::size_t i = 0; i < cow.triangles.size(); i += 2) std::swap(cow.triangles[i].y, cow.triangles[i].z);
    mesh::repair(cow);
    EXPECT_NEAR(mesh::signedVolume(cow), cowVolume, 1e-9 * cowVolume);
    EXPECT_EQ(mesh::check(cow).misorientedEdges, 0u);
}

TEST(Repair, ReportsWhatCannotBeFixed) {
    // A Moebius strip of 12 quads: non-orientable, open.
    mesh::TriMesh m;
    const int n = 12;
    for (int i = 0; i < n; ++i) {
        const double a = 2 * M_PI * i / n, half = a / 2;
        for (int s : {-1, 1}) {
            const double w = 0.3 * s;
            m.positions.emplace_back(float((1 + w * std::cos(half)) * std::cos(a)),
                                     float((1 + w * std::cos(half)) * std::sin(a)), float(w * std::sin(half)));
        }
    }
    for (std::uint32_t i = 0; i < n; ++i) {
        const std::uint32_t a = 2 * i, b = 2 * i + 1;
        std::uint32_t c = 2 * ((i + 1) % n), d = c + 1;
        if (i == n - 1) std::swap(c, d);  // the half twist
        m.triangles.push_back({a, c, d});
        m.triangles.push_back({a, d, b});
    }
    const mesh::RepairReport r = mesh::repair(m);
    EXPECT_EQ(r.nonOrientableComponents, 1u);
    EXPECT_EQ(r.openComponents, 1u);
    EXPECT_NE(r.toString().find("NOT FIXED"), std::string::npos);
}
