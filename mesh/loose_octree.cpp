#include "mesh/loose_octree.h"

#include <algorithm>
#include <cmath>

namespace isoforge::mesh {

namespace {
constexpr int kMaxLevel = 40;  // 2^40 leaves a side: beyond any mesh (the stack of query() holds 64 levels)
}

LooseOctree::LooseOctree(const glm::dvec3& lo, const glm::dvec3& hi, double leaf)
    : origin_(lo), leaf_(leaf > 0 && std::isfinite(leaf) ? leaf : 1.0) {
    const glm::dvec3 extent = hi - lo;
    const double span = std::max({extent.x, extent.y, extent.z, 0.0});
    while (top_ < kMaxLevel && std::ldexp(leaf_, top_) < span) ++top_;
    for (int l = 0; l <= top_; ++l) size_.push_back(std::ldexp(leaf_, l));
    nodes_.emplace_back();
    nodes_[0].level = top_;
    nodes_[0].lo = origin_;
}

void LooseOctree::insert(std::uint32_t id, const glm::dvec3& lo, const glm::dvec3& hi) {
    if (where_.size() <= id) where_.resize(std::size_t(id) + 1, kNone);
    const glm::dvec3 extent = hi - lo;
    const double span = std::max({extent.x, extent.y, extent.z, 0.0});
    int level = 0;
    while (level < top_ && size_[static_cast<std::size_t>(level)] < span) ++level;
    // Leaf coordinates of the lower corner; a node's cell at level l is the leaf's shifted right by l
    // (exact: the same integer at every level, so a box and its ancestors always agree).
    const glm::dvec3 t = (lo - origin_) / leaf_;
    const double cells = std::ldexp(1.0, top_);
    if (!(span <= size_[static_cast<std::size_t>(top_)]) || !(t.x >= 0 && t.y >= 0 && t.z >= 0) ||
        !(t.x < cells && t.y < cells && t.z < cells)) {
        where_[id] = kOutside;
        outside_.push_back({lo, hi, id});
        return;
    }
    const std::int64_t c[3] = {std::int64_t(std::floor(t.x)), std::int64_t(std::floor(t.y)),
                               std::int64_t(std::floor(t.z))};
    std::int32_t n = 0;
    ++nodes_[0].count;
    for (int l = top_ - 1; l >= level; --l) {
        int k = 0;
        for (int a = 0; a < 3; ++a) k |= int((c[a] >> l) & 1) << a;
        std::int32_t next = nodes_[static_cast<std::size_t>(n)].child[k];
        if (next < 0) {
            next = static_cast<std::int32_t>(nodes_.size());
            Node child;
            child.parent = n;
            child.level = l;
            const double s = size_[static_cast<std::size_t>(l)];
            child.lo = origin_ + glm::dvec3(double(c[0] >> l) * s, double(c[1] >> l) * s, double(c[2] >> l) * s);
            nodes_.push_back(std::move(child));
            nodes_[static_cast<std::size_t>(n)].child[k] = next;
        }
        n = next;
        ++nodes_[static_cast<std::size_t>(n)].count;
    }
    nodes_[static_cast<std::size_t>(n)].items.push_back({lo, hi, id});
    where_[id] = n;
}

void LooseOctree::remove(std::uint32_t id) {
    if (id >= where_.size() || where_[id] == kNone) return;
    auto drop = [id](std::vector<Item>& list) {
        const auto it = std::find_if(list.begin(), list.end(), [id](const Item& b) { return b.id == id; });
        if (it != list.end()) list.erase(it);  // keeps the order: queries stay deterministic and simple
    };
    if (where_[id] == kOutside) {
        drop(outside_);
    } else {
        std::int32_t n = where_[id];
        drop(nodes_[static_cast<std::size_t>(n)].items);
        for (; n >= 0; n = nodes_[static_cast<std::size_t>(n)].parent) --nodes_[static_cast<std::size_t>(n)].count;
    }
    where_[id] = kNone;
}

}  // namespace isoforge::mesh
