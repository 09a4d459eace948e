#pragma once
/// @file A field cut into a uniform grid of cubic cells for ray marching: each cell is classified by
/// the field's interval bound over it (all outside, all inside, or where the surface may be), and a
/// cell where the surface may be carries the field simplified to it (CSG pruning, tape
/// simplification). Rays walk the cells they cross, nearest first (a 3D DDA), skip the classified
/// ones and march only inside the others, each with its few nodes. The grid is built once per frame
/// by recursive subdivision of the region (a node whose bound excludes 0 fills its cells at once), so
/// its cost follows the surface; primary, shadow and occlusion rays share it.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "implicit/field.h"

namespace isoforge::render::detail {

class FieldGrid {
public:
    FieldGrid() = default;  ///< no cells: walk() visits nothing
    /// Cells of size longest side / `cellsAlongLongest` over `region` (bounded, not empty).
    FieldGrid(const implicit::FieldPtr& field, const implicit::Box3& region, int cellsAlongLongest);

    static constexpr std::int32_t kOutside = -2;  ///< the field is positive over the whole cell
    static constexpr std::int32_t kInside = -1;   ///< negative over the whole cell

    /// Calls visit(code, t0, t1) for the cells the ray origin + t dir crosses within [t0, t1],
    /// nearest first; `code` is kOutside, kInside, or the index of the cell's field (field(code)).
    /// Stops when visit returns true; returns whether it did.
    template <class Visit>
    bool walk(const glm::vec3& origin, const glm::vec3& dir, float t0, float t1, Visit&& visit) const;

    const implicit::Field& field(std::int32_t code) const { return *fields_[std::size_t(code)]; }
    /// Every surface in the cell is translucent (implicit::Field::translucent): shadow rays pass.
    bool seeThrough(std::int32_t code) const { return seeThrough_[std::size_t(code)] != 0; }
    std::size_t surfaceCells() const { return fields_.size(); }
    std::size_t cells() const { return code_.size(); }

private:
    glm::ivec3 n_{0};
    glm::vec3 min_{0.f};
    float h_ = 1.f;
    std::vector<std::int32_t> code_;
    std::vector<implicit::FieldPtr> fields_;
    std::vector<char> seeThrough_;
    /// Per cell, 1 + how many rings of cells around it are outside too (chessboard distance to the
    /// nearest cell that is not outside, capped): walks cross empty space in steps of many cells.
    std::vector<std::uint8_t> clear_;
};

template <class Visit>
bool FieldGrid::walk(const glm::vec3& origin, const glm::vec3& dir, float t0, float t1, Visit&& visit) const {
    if (!(t1 > t0) || code_.empty()) return false;
    const glm::vec3 p = origin + t0 * dir;
    int i[3], step[3];
    float tMax[3], tDelta[3];
    const int n[3] = {n_.x, n_.y, n_.z};
    for (int k = 0; k < 3; ++k) {
        i[k] = std::clamp(static_cast<int>(std::floor((p[k] - min_[k]) / h_)), 0, n[k] - 1);
        if (dir[k] > 0.f) {
            step[k] = 1;
            tMax[k] = (min_[k] + float(i[k] + 1) * h_ - origin[k]) / dir[k];
            tDelta[k] = h_ / dir[k];
        } else if (dir[k] < 0.f) {
            step[k] = -1;
            tMax[k] = (min_[k] + float(i[k]) * h_ - origin[k]) / dir[k];
            tDelta[k] = -h_ / dir[k];
        } else {
            step[k] = 0;
            tMax[k] = tDelta[k] = INFINITY;
        }
    }
    float t = t0;
    for (;;) {
        const std::size_t c =
            (std::size_t(i[2]) * std::size_t(n_.y) + std::size_t(i[1])) * std::size_t(n_.x) + std::size_t(i[0]);
        if (const int r = int(clear_[c]) - 1; r > 0) {
            // Every cell within r of this one is outside: leave the cube of them in one step.
            float exit = INFINITY;
            int k = 0;
            for (int a = 0; a < 3; ++a) {
                if (step[a] == 0) continue;
                const int face = step[a] > 0 ? i[a] + r + 1 : i[a] - r;
                const float tf = (min_[a] + float(face) * h_ - origin[a]) / dir[a];
                if (tf < exit) exit = tf, k = a;
            }
            exit = std::min(std::max(exit, t), t1);
            if (visit(kOutside, t, exit)) return true;
            if (exit >= t1) return false;
            const glm::vec3 q = origin + exit * dir;
            for (int a = 0; a < 3; ++a) {
                const int lo = std::max(i[a] - r, 0), hi = std::min(i[a] + r, n[a] - 1);
                i[a] = a == k ? i[a] + step[a] * (r + 1)
                              : std::clamp(static_cast<int>(std::floor((q[a] - min_[a]) / h_)), lo, hi);
            }
            if (i[k] < 0 || i[k] >= n[k]) return false;
            for (int a = 0; a < 3; ++a)
                if (step[a] != 0) tMax[a] = (min_[a] + float(i[a] + (step[a] > 0)) * h_ - origin[a]) / dir[a];
            t = exit;
            continue;
        }
        const int k = tMax[0] < tMax[1] ? (tMax[0] < tMax[2] ? 0 : 2) : (tMax[1] < tMax[2] ? 1 : 2);
        const float exit = std::min(std::max(tMax[k], t), t1);
        if (visit(code_[c], t, exit)) return true;
        if (exit >= t1) return false;
        i[k] += step[k];
        if (i[k] < 0 || i[k] >= n[k]) return false;
        t = exit;
        tMax[k] += tDelta[k];
    }
}

}  // namespace isoforge::render::detail
