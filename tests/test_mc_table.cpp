#include <set>

#include <gtest/gtest.h>

#include "volume/mc_table.h"

using namespace isoforge::volume::mc;

namespace {
int corner(int e, int end) {
    EdgeInfo i = edgeInfo(e);
    int c = i.dx | (i.dy << 1) | (i.dz << 2);
    return end ? c | (1 << i.axis) : c;
}
}  // namespace

TEST(McTable, EdgesAreTheTwelveCubeEdges) {
    std::set<std::pair<int, int>> edges;
    for (int e = 0; e < 12; ++e) {
        int a = corner(e, 0), b = corner(e, 1);
        EXPECT_EQ(__builtin_popcount(a ^ b), 1);
        edges.insert({a, b});
    }
    EXPECT_EQ(edges.size(), 12u);
}

TEST(McTable, EveryCaseUsesExactlyItsCutEdges) {
    const CaseTable& t = caseTable();
    EXPECT_EQ(t.triangleCount[0], 0);
    EXPECT_EQ(t.triangleCount[255], 0);
    for (int code = 0; code < 256; ++code) {
        std::set<int> cut, used;
        for (int e = 0; e < 12; ++e)
            if (((code >> corner(e, 0)) & 1) != ((code >> corner(e, 1)) & 1)) cut.insert(e);
        for (int k = 0; k < 3 * t.triangleCount[code]; ++k) used.insert(t.edges[code][k]);
        EXPECT_EQ(cut, used) << "case " << code;
        // Each triangle names three distinct edges.
        for (int k = 0; k < t.triangleCount[code]; ++k) {
            auto* tri = &t.edges[code][3 * k];
            EXPECT_TRUE(tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2]) << "case " << code;
        }
    }
}

TEST(McTable, SingleCornerCaseIsOneOutwardTriangle) {
    // Corner 0 inside: the triangle must face away from corner 0, towards (1, 1, 1).
    const CaseTable& t = caseTable();
    ASSERT_EQ(t.triangleCount[1], 1);
    auto mid = [](int e) {
        EdgeInfo i = edgeInfo(e);
        double p[3] = {double(i.dx), double(i.dy), double(i.dz)};
        p[i.axis] += 0.5;
        return std::array<double, 3>{p[0], p[1], p[2]};
    };
    auto a = mid(t.edges[1][0]), b = mid(t.edges[1][1]), c = mid(t.edges[1][2]);
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    EXPECT_GT(n[0] + n[1] + n[2], 0.0);
}
