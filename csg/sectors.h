#pragma once
/// @file The sectors of a regular polygon or of a faceted revolution, found without trigonometry.
///
/// OpenSCAD facets a circle of `$fn` segments as n equal sectors. The facet a point sees is the
/// sector whose middle direction is nearest the point's angle, which is also the one whose middle
/// direction has the largest dot product with the point: that dot product is the point's
/// "faceted radius", the support function every faceted field (regular polygons, `$fn` spheres and
/// cylinders, faceted rotate_extrude) is built on. Computing it with atan2, floor, cos and sin took
/// 90% of the time of models made of `$fn` spheres. Here a polynomial atan2 (error below 3.5e-6 rad)
/// guesses the sector, and the sector and its neighbours within that error are compared by their
/// dot products with the middle directions, read from a table: the same sector as the exact
/// computation (the largest dot product wins; at a boundary both sides give the same value).

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/fast_atan2.h"

namespace isoforge::csg {

class Sectors {
public:
    /// `count` sectors of angle `step` each, the first starting at angle `start` (radians, from +x,
    /// counter-clockwise). `closed`: they make a full turn, so the last one neighbours the first.
    Sectors(int count, double step, double start, bool closed)
        : n_(count), step_(step), invStep_(1.0 / step), start_(start), closed_(closed) {
        // The guess is off by at most the polynomial's error (and rounding): look that far around.
        reach_ = 1 + static_cast<int>(kGuessError / step_);
        if (n_ <= kMaxTable) {
            dirs_.resize(2 * static_cast<std::size_t>(n_));
            for (int k = 0; k < n_; ++k) {
                const double mid = middle(k);
                dirs_[2 * std::size_t(k)] = std::cos(mid);
                dirs_[2 * std::size_t(k) + 1] = std::sin(mid);
            }
        }
    }

    /// The largest dot product of (x, y) with a sector's middle direction (over the sectors a point
    /// at this angle can be in; for an open fan, the nearest sector of the fan).
    double support(double x, double y) const {
        double phi = atan2Approx(y, x) - start_;
        phi -= 2 * M_PI * std::floor(phi * (0.5 / M_PI));  // into [0, 2 pi), whatever the start
        // phi is in [0, 2 pi), so the guess is in [0, n] for a full turn: no division to wrap it.
        // (An open fan's may be far past its end, and a NaN point has none: clamped.)
        double g = std::min(phi * invStep_, double(n_));
        if (!(g >= 0)) g = 0;
        const int guess = static_cast<int>(g);
        double best = -HUGE_VAL;
        for (int k = guess - reach_; k <= guess + reach_; ++k) {
            int j = k;
            if (closed_) {
                while (j < 0) j += n_;
                while (j >= n_) j -= n_;
            } else {
                j = std::clamp(j, 0, n_ - 1);
            }
            best = std::max(best, dot(j, x, y));
        }
        // An open fan: a point near its start may be guessed a turn away; the ends are candidates too
        // (a larger dot product is a nearer sector, so extra candidates never pick a wrong one).
        if (!closed_) best = std::max({best, dot(0, x, y), dot(n_ - 1, x, y)});
        return best;
    }

    static double atan2Approx(double y, double x) { return fastAtan2(y, x); }
    static constexpr double kGuessError = 1e-5;  // above kFastAtan2Error, with room for rounding

private:
    static constexpr int kMaxTable = 1 << 16;  // beyond this many sectors, cos and sin on the fly
    double middle(int k) const { return start_ + (k + 0.5) * step_; }
    double dot(int k, double x, double y) const {
        if (!dirs_.empty()) return x * dirs_[2 * std::size_t(k)] + y * dirs_[2 * std::size_t(k) + 1];
        const double mid = middle(k);
        return x * std::cos(mid) + y * std::sin(mid);
    }
    int n_;
    double step_, invStep_, start_;
    bool closed_;
    int reach_ = 1;
    std::vector<double> dirs_;
};

}  // namespace isoforge::csg
