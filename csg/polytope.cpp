#include "csg/polytope.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

namespace isoforge::csg {

using implicit::Box3;
using implicit::FieldPtr;
using implicit::Interval;

namespace {

/// A plane n . p = d with a unit normal, in double (bounds) and float (values).
struct Plane {
    glm::dvec3 n;
    double d;
};

class ConvexPolytope final : public implicit::Field {
public:
    ConvexPolytope(std::vector<Plane> planes, Box3 box, double slack, std::string what)
        : planes_(std::move(planes)), box_(box), slack_(slack), what_(std::move(what)) {
        nx_.reserve(planes_.size());
        for (const Plane& p : planes_) {
            nx_.push_back(float(p.n.x));
            ny_.push_back(float(p.n.y));
            nz_.push_back(float(p.n.z));
            d_.push_back(float(p.d));
        }
    }

    float value(const glm::vec3& p) const override {
        float v = -INFINITY;
        for (std::size_t i = 0; i < nx_.size(); ++i)
            v = std::max(v, nx_[i] * p.x + ny_[i] * p.y + nz_[i] * p.z - d_[i]);
        return v;
    }
    void values(std::span<const glm::vec3> p, std::span<float> out) const override {
        std::fill(out.begin(), out.end(), -INFINITY);
        for (std::size_t i = 0; i < nx_.size(); ++i) {
            const float a = nx_[i], b = ny_[i], c = nz_[i], d = d_[i];
            for (std::size_t k = 0; k < p.size(); ++k)
                out[k] = std::max(out[k], a * p[k].x + b * p[k].y + c * p[k].z - d);
        }
    }
    Interval bound(const Box3& box) const override {
        double lo = -INFINITY, hi = -INFINITY;
        for (const Plane& pl : planes_) {
            const Interval r = range(pl, box);
            lo = std::max(lo, double(r.lo));
            hi = std::max(hi, double(r.hi));
        }
        return {float(lo), float(hi)};
    }
    Box3 bounds() const override { return box_; }
    bool cheapGradient() const override { return true; }
    bool valueFirst() const override { return true; }
    glm::vec3 gradient(const glm::vec3& p) const override {
        float v = -INFINITY;
        std::size_t best = 0;
        for (std::size_t i = 0; i < nx_.size(); ++i) {
            const float w = nx_[i] * p.x + ny_[i] * p.y + nz_[i] * p.z - d_[i];
            if (w > v) v = w, best = i;
        }
        return glm::vec3(planes_[best].n);
    }
    FieldPtr simplify(const Box3& box) const override {
        if (planes_.size() <= 4) return nullptr;
        std::vector<Interval> r;
        r.reserve(planes_.size());
        float floor = -INFINITY;
        for (const Plane& pl : planes_) {
            r.push_back(range(pl, box));
            floor = std::max(floor, r.back().lo);
        }
        std::vector<Plane> kept;
        for (std::size_t i = 0; i < planes_.size(); ++i)
            if (r[i].hi >= floor) kept.push_back(planes_[i]);
        if (kept.size() == planes_.size()) return nullptr;
        return std::make_shared<ConvexPolytope>(std::move(kept), box_, slack_, what_);
    }
    std::string describe() const override { return what_ + " (" + std::to_string(planes_.size()) + " planes)"; }

private:
    /// The plane's values over the box, widened by the rounding of float evaluation.
    Interval range(const Plane& pl, const Box3& box) const {
        const glm::dvec3 c = 0.5 * (glm::dvec3(box.min) + glm::dvec3(box.max));
        const glm::dvec3 h = 0.5 * (glm::dvec3(box.max) - glm::dvec3(box.min));
        const double mid = glm::dot(pl.n, c) - pl.d;
        const double half = glm::dot(glm::abs(pl.n), h);
        const double slack = slack_ + 1e-6 * glm::dot(glm::abs(pl.n), glm::abs(c) + h);
        return {float(mid - half - slack), float(mid + half + slack)};
    }

    std::vector<Plane> planes_;
    std::vector<float> nx_, ny_, nz_, d_;
    Box3 box_;
    double slack_;
    std::string what_;
};

}  // namespace

FieldPtr makeConvexPolytope(const mesh::ConvexHull& hull, std::string what) {
    if (hull.empty()) throw std::invalid_argument(what + " is empty (its points do not span a solid)");
    Box3 box;
    double extent = 0;
    for (const glm::dvec3& p : hull.points) {
        box.min = glm::min(box.min, glm::vec3(p));
        box.max = glm::max(box.max, glm::vec3(p));
        extent = std::max({extent, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
    }
    // One plane per face: coplanar triangles of a face give (nearly) the same plane; keep the
    // first of each group in a deterministic order.
    const double tol = 1e-9 * std::max(extent, 1.0);
    struct Candidate {
        Plane plane;
        bool check;  // whether its rounding could put a point of the hull past tol (below)
    };
    std::vector<Candidate> c;
    for (const glm::uvec3& t : hull.triangles) {
        const glm::dvec3 a = hull.points[t.x], b = hull.points[t.y], q = hull.points[t.z];
        const glm::dvec3 e1 = b - a, e2 = q - a;
        const glm::dvec3 n = glm::cross(e1, e2);
        const double len = glm::length(n);
        if (!(len > 0)) continue;
        const glm::dvec3 u = n / len;
        // The hull was made with exact predicates: every point p has (p - a) . n <= 0 for the exact
        // normal n of the triangle. The computed one differs from it by at most about
        // 10 eps |e1| |e2| (the differences and the cross product rounded), which tilts the unit
        // normal by 10 eps kappa, kappa = |e1| |e2| / |n| (1 / the sine of the angle at a); over
        // |p - a| <= 2 sqrt(3) extent, with the dot products' own rounding, a point can be past the
        // plane by at most 64 eps (kappa + 1) extent. Only a sliver (kappa over about 10^4) can
        // get near tol, and only its plane is checked against every point: the check costs
        // planes x points, which for a hull of 20,000 points took seconds.
        const double kappa = glm::length(e1) * glm::length(e2) / len;
        const bool check = !(64 * DBL_EPSILON * (kappa + 1) * std::max(extent, 1.0) < 0.25 * tol);
        c.push_back({{u, glm::dot(u, a)}, check});
    }
    std::sort(c.begin(), c.end(), [](const Candidate& x, const Candidate& y) {
        if (x.plane.n.x != y.plane.n.x) return x.plane.n.x < y.plane.n.x;
        if (x.plane.n.y != y.plane.n.y) return x.plane.n.y < y.plane.n.y;
        if (x.plane.n.z != y.plane.n.z) return x.plane.n.z < y.plane.n.z;
        if (x.plane.d != y.plane.d) return x.plane.d < y.plane.d;
        return x.check < y.check;
    });
    std::vector<Candidate> kept;
    for (const Candidate& k : c) {
        bool same = false;
        for (std::size_t j = kept.size(); j-- > 0 && !same;) {
            if (kept[j].plane.n.x < k.plane.n.x - 1e-9) break;  // sorted by x: no nearer one before
            same = glm::length(kept[j].plane.n - k.plane.n) < 1e-9 && std::abs(kept[j].plane.d - k.plane.d) < tol;
        }
        if (!same) kept.push_back(k);
    }
    // A sliver triangle (points a rounding error apart, as clipped or summed points make them) has a
    // normal that means nothing: keep only planes with every point of the hull on their inner side.
    // The rest still bound the hull (dropping a plane only ever adds the sliver's width).
    std::vector<Plane> planes;
    planes.reserve(kept.size());
    for (const Candidate& k : kept) {
        const bool outside = k.check && std::any_of(hull.points.begin(), hull.points.end(), [&](const glm::dvec3& p) {
                                 return glm::dot(k.plane.n, p) - k.plane.d > tol;
                             });
        if (!outside) planes.push_back(k.plane);
    }
    if (planes.size() < 4) throw std::invalid_argument(what + " is flat");
    // The rounding of a float evaluation: a few units in the last place of the largest coordinate.
    const double slack = 4 * extent * 1.2e-7;
    box = box.expanded(float(slack));
    return std::make_shared<ConvexPolytope>(std::move(planes), box, slack, std::move(what));
}

}  // namespace isoforge::csg
