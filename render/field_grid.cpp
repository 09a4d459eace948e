#include "render/field_grid.h"

#include <algorithm>
#include <utility>

#include <tbb/concurrent_vector.h>
#include <tbb/task_group.h>
#include <glm/common.hpp>

namespace isoforge::render::detail {

namespace {

struct Builder {
    const glm::vec3 min;
    const float h, margin;
    const glm::ivec3 n;
    std::vector<std::int32_t>& code;
    tbb::concurrent_vector<std::pair<std::size_t, implicit::FieldPtr>> surface;

    std::size_t index(int x, int y, int z) const {
        return (std::size_t(z) * std::size_t(n.y) + std::size_t(y)) * std::size_t(n.x) + std::size_t(x);
    }
    void fill(const glm::ivec3& lo, const glm::ivec3& hi, std::int32_t c) {
        for (int z = lo.z; z < hi.z; ++z)
            for (int y = lo.y; y < hi.y; ++y)
                std::fill_n(code.begin() + std::ptrdiff_t(index(lo.x, y, z)), hi.x - lo.x, c);
    }
    /// Cells [lo, hi) under field f (already simplified to an enclosing node's box).
    void build(const implicit::FieldPtr& f, const glm::ivec3& lo, const glm::ivec3& hi, int depth) {
        // A node's box is its cells' union grown by the margin: points a ray takes in a cell lie in
        // the cell's box up to rounding, and the field simplified to the grown box equals the whole
        // field there.
        const implicit::Box3 box{min + glm::vec3(lo) * h - glm::vec3(margin),
                                 min + glm::vec3(hi) * h + glm::vec3(margin)};
        const implicit::Pruned p = f->prune(box);
        if (p.bound.lo > 0.f) return fill(lo, hi, FieldGrid::kOutside);
        if (p.bound.hi < 0.f) return fill(lo, hi, FieldGrid::kInside);
        const implicit::FieldPtr g = p.field ? p.field : f;
        const glm::ivec3 size = hi - lo;
        if (size.x == 1 && size.y == 1 && size.z == 1) {
            code[index(lo.x, lo.y, lo.z)] = 0;
            surface.emplace_back(index(lo.x, lo.y, lo.z), g);
            return;
        }
        const glm::ivec3 mid = lo + (size + 1) / 2;
        tbb::task_group tasks;
        for (int c = 0; c < 8; ++c) {
            glm::ivec3 a, b;
            bool empty = false;
            for (int k = 0; k < 3; ++k) {
                a[k] = (c >> k & 1) ? mid[k] : lo[k];
                b[k] = (c >> k & 1) ? hi[k] : mid[k];
                empty |= a[k] >= b[k];
            }
            if (empty) continue;
            if (depth < 3)
                tasks.run([this, g, a, b, depth] { build(g, a, b, depth + 1); });
            else
                build(g, a, b, depth + 1);
        }
        tasks.wait();
    }
};

/// Chessboard distance (in cells, capped at kCap) from each cell to the nearest cell that is not
/// outside: exact 1D distances along x, then the min-max composition along y and z (the L-infinity
/// distance is separable that way), each over offsets up to the cap.
constexpr int kCap = 16;
std::vector<std::uint8_t> clearance(const std::vector<std::int32_t>& code, const glm::ivec3& n) {
    std::vector<std::uint8_t> d(code.size());
    const std::size_t nx = std::size_t(n.x), nxy = nx * std::size_t(n.y);
    for (std::size_t c = 0; c < code.size(); ++c) d[c] = code[c] == FieldGrid::kOutside ? kCap : 0;
    for (std::size_t row = 0; row < code.size(); row += nx) {
        for (std::size_t x = 1; x < nx; ++x) d[row + x] = std::min<int>(d[row + x], d[row + x - 1] + 1);
        for (std::size_t x = nx - 1; x-- > 0;) d[row + x] = std::min<int>(d[row + x], d[row + x + 1] + 1);
    }
    std::vector<std::uint8_t> e(d.size());
    auto along = [&](int axis) {
        const int len = n[axis];
        const std::size_t stride = axis == 1 ? nx : nxy;
        for (std::size_t c = 0; c < d.size(); ++c) {
            const int at = axis == 1 ? int(c / nx % std::size_t(n.y)) : int(c / nxy);
            int best = d[c];
            for (int o = 1; o < best; ++o) {
                if (at - o >= 0) best = std::min(best, std::max(o, int(d[c - std::size_t(o) * stride])));
                if (at + o < len) best = std::min(best, std::max(o, int(d[c + std::size_t(o) * stride])));
            }
            e[c] = static_cast<std::uint8_t>(best);
        }
        d.swap(e);
    };
    along(1);
    along(2);
    return d;
}

}  // namespace

FieldGrid::FieldGrid(const implicit::FieldPtr& field, const implicit::Box3& region, int cellsAlongLongest) {
    const glm::vec3 size = region.size();
    h_ = std::max({size.x, size.y, size.z}) / float(std::max(cellsAlongLongest, 1));
    if (!(h_ > 0.f) || !std::isfinite(h_)) return;
    min_ = region.min;
    for (int k = 0; k < 3; ++k) n_[k] = std::max(1, static_cast<int>(std::ceil(size[k] / h_)));
    code_.assign(std::size_t(n_.x) * std::size_t(n_.y) * std::size_t(n_.z), kOutside);
    const glm::vec3 extent = glm::max(glm::abs(region.min), glm::abs(region.max));
    Builder b{min_, h_, h_ / 64.f + 2e-4f * std::max({extent.x, extent.y, extent.z}), n_, code_, {}};
    b.build(field, glm::ivec3(0), n_, 0);
    // Fields in cell order, so that nothing depends on the order the threads appended them in.
    std::vector<std::pair<std::size_t, implicit::FieldPtr>> s(b.surface.begin(), b.surface.end());
    std::sort(s.begin(), s.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    fields_.reserve(s.size());
    seeThrough_.reserve(s.size());
    for (auto& [c, f] : s) {
        code_[c] = static_cast<std::int32_t>(fields_.size());
        seeThrough_.push_back(f->translucent(false) ? 1 : 0);
        fields_.push_back(std::move(f));
    }
    clear_ = clearance(code_, n_);
}

}  // namespace isoforge::render::detail
