#pragma once
/// @file A loose octree of boxes that come and go: the triangles of mesh/simplify.cpp, whose sizes
/// grow from a voxel to a whole flat face as the mesh is simplified.
///
/// A box lives in one node: at the first level whose cells are at least as large as the box, in the
/// cell that holds its lower corner. It then lies within twice that cell, and so does everything below
/// the node. A query visits only nodes with something in or below them whose doubled cell meets the
/// query box, so its cost follows the boxes near it, not the area it covers (a uniform hash of small
/// cells visits every cell a large triangle spans; of large cells, every small triangle in them).

#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

namespace isoforge::mesh {

class LooseOctree {
public:
    /// Boxes are expected within [lo, hi]; any other goes to a list that every query visits. `leaf` is
    /// the size of the smallest cell (about the smallest boxes' size).
    LooseOctree(const glm::dvec3& lo, const glm::dvec3& hi, double leaf);

    /// Adds box `id` (ids are small integers: an index per triangle). An id must not be in twice.
    void insert(std::uint32_t id, const glm::dvec3& lo, const glm::dvec3& hi);
    /// Takes box `id` out (nothing if it is not in).
    void remove(std::uint32_t id);

    /// Calls f(id) for each box that meets [lo, hi] (touching counts) until f returns true; returns
    /// whether one did. Deterministic: the order follows the inserts and removals.
    template <class F>
    bool query(const glm::dvec3& lo, const glm::dvec3& hi, F&& f) const {
        auto meets = [&](const Item& b) {
            return !(b.lo.x > hi.x || b.lo.y > hi.y || b.lo.z > hi.z || b.hi.x < lo.x || b.hi.y < lo.y ||
                     b.hi.z < lo.z);
        };
        for (const Item& b : outside_)
            if (meets(b) && f(b.id)) return true;
        std::int32_t stack[64 * 8];
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const Node& n = nodes_[static_cast<std::size_t>(stack[--top])];
            const double reach = 2.0 * size_[n.level];
            if (n.lo.x > hi.x || n.lo.y > hi.y || n.lo.z > hi.z || n.lo.x + reach < lo.x || n.lo.y + reach < lo.y ||
                n.lo.z + reach < lo.z)
                continue;
            for (const Item& b : n.items)
                if (meets(b) && f(b.id)) return true;
            for (std::int32_t c : n.child)
                if (c >= 0 && nodes_[static_cast<std::size_t>(c)].count > 0) stack[top++] = c;
        }
        return false;
    }

private:
    struct Item {
        glm::dvec3 lo, hi;
        std::uint32_t id;
    };
    struct Node {
        std::int32_t child[8] = {-1, -1, -1, -1, -1, -1, -1, -1};
        std::int32_t parent = -1;
        std::uint32_t count = 0;  // boxes in this node and below it
        int level = 0;
        glm::dvec3 lo{0.0};  // the cell's lower corner
        std::vector<Item> items;
    };
    static constexpr std::int32_t kNone = -1, kOutside = -2;

    std::vector<Node> nodes_;          // nodes_[0] is the root, at level top_
    std::vector<double> size_;         // cell size per level
    std::vector<std::int32_t> where_;  // id -> node, kNone or kOutside
    std::vector<Item> outside_;        // boxes beyond the root
    glm::dvec3 origin_;
    double leaf_;
    int top_ = 0;
};

}  // namespace isoforge::mesh
