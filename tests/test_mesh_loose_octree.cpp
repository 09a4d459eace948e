#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "mesh/loose_octree.h"

using namespace isoforge;
using glm::dvec3;

namespace {

struct Box {
    dvec3 lo, hi;
    bool in = false;
};

bool meets(const Box& b, const dvec3& lo, const dvec3& hi) {
    return !(b.lo.x > hi.x || b.lo.y > hi.y || b.lo.z > hi.z || b.hi.x < lo.x || b.hi.y < lo.y || b.hi.z < lo.z);
}

}  // namespace

TEST(LooseOctree, QueriesFindExactlyTheBoxesThatMeetThemAsBoxesComeAndGo) {
    // Boxes from a hundredth of the domain to all of it, some past its edges and some flat (a triangle in
    // an axis plane), inserted and removed at random: every query reports each box that meets it once
    // (touching counts) and no other, against a brute-force scan.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    mesh::LooseOctree tree(dvec3(-1.0), dvec3(9.0), 0.05);
    std::vector<Box> boxes(3000);
    auto randomBox = [&] {
        Box b;
        const double size = 0.01 * std::pow(1000.0, unit(rng));  // 0.01 .. 10, log-uniform
        for (int a = 0; a < 3; ++a) {
            b.lo[a] = -2.0 + 12.0 * unit(rng);
            b.hi[a] = b.lo[a] + size * unit(rng);
        }
        if (unit(rng) < 0.2) b.hi.z = b.lo.z;  // flat
        return b;
    };
    for (int round = 0; round < 20; ++round) {
        for (std::uint32_t id = 0; id < boxes.size(); ++id) {
            if (unit(rng) < 0.3) {
                if (boxes[id].in) tree.remove(id);
                boxes[id] = randomBox();
                tree.insert(id, boxes[id].lo, boxes[id].hi);
                boxes[id].in = true;
            } else if (unit(rng) < 0.1 && boxes[id].in) {
                tree.remove(id);
                boxes[id].in = false;
            }
        }
        for (int q = 0; q < 50; ++q) {
            const Box query = randomBox();
            std::vector<std::uint32_t> found, expected;
            EXPECT_FALSE(tree.query(query.lo, query.hi, [&](std::uint32_t id) {
                found.push_back(id);
                return false;
            }));
            for (std::uint32_t id = 0; id < boxes.size(); ++id)
                if (boxes[id].in && meets(boxes[id], query.lo, query.hi)) expected.push_back(id);
            std::sort(found.begin(), found.end());
            ASSERT_EQ(found, expected) << "round " << round << ", query " << q;
        }
    }
    // A box that touches the query at one corner counts; the query stops when asked to.
    mesh::LooseOctree small(dvec3(0.0), dvec3(1.0), 0.1);
    small.insert(0, dvec3(0.2), dvec3(0.3));
    small.insert(1, dvec3(0.3), dvec3(0.4));
    int calls = 0;
    EXPECT_TRUE(small.query(dvec3(0.3), dvec3(0.3), [&](std::uint32_t) { return ++calls == 1; }));
    EXPECT_EQ(calls, 1);
    small.remove(0);
    small.remove(0);  // twice: nothing
    std::vector<std::uint32_t> left;
    small.query(dvec3(0.0), dvec3(1.0), [&](std::uint32_t id) {
        left.push_back(id);
        return false;
    });
    EXPECT_EQ(left, std::vector<std::uint32_t>{1});
}
