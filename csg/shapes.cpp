#include "csg/shapes.h"

#include "csg/sectors.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

namespace isoforge::csg {

using implicit::Box3;
using implicit::Interval;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

/// A 2D shape: field of (x, y), constant along z.
template <class Derived>
class Shape2D : public implicit::Field {
public:
    float value(const glm::vec3& p) const override { return self().eval(glm::vec2(p.x, p.y)); }
    Interval bound(const Box3& b) const override {
        const glm::vec2 c(0.5f * (b.min.x + b.max.x), 0.5f * (b.min.y + b.max.y));
        const float r = 0.5f * glm::length(glm::vec2(b.max.x - b.min.x, b.max.y - b.min.y));
        return implicit::lipschitz(self().eval(c), 1.f, r);
    }
    Box3 bounds() const override {
        const auto [lo, hi] = self().extent();
        return {glm::vec3(lo, -kInf), glm::vec3(hi, kInf)};
    }

private:
    const Derived& self() const { return static_cast<const Derived&>(*this); }
};

class Circle2D final : public Shape2D<Circle2D> {
public:
    explicit Circle2D(float r) : r_(r) {}
    float eval(glm::vec2 p) const { return glm::length(p) - r_; }
    std::pair<glm::vec2, glm::vec2> extent() const { return {glm::vec2(-r_), glm::vec2(r_)}; }
    std::string describe() const override { return "circle(r=" + std::to_string(r_) + ")"; }

private:
    float r_;
};

class Rectangle2D final : public Shape2D<Rectangle2D> {
public:
    Rectangle2D(glm::vec2 lo, glm::vec2 hi) : c_(0.5f * (lo + hi)), h_(0.5f * (hi - lo)) {}
    float eval(glm::vec2 p) const {
        const glm::vec2 q = glm::abs(p - c_) - h_;
        return glm::length(glm::max(q, glm::vec2(0.f))) + std::min(std::max(q.x, q.y), 0.f);
    }
    std::pair<glm::vec2, glm::vec2> extent() const { return {c_ - h_, c_ + h_}; }
    std::string describe() const override { return "square"; }

private:
    glm::vec2 c_, h_;
};

class Polygon2D final : public Shape2D<Polygon2D> {
public:
    Polygon2D(std::vector<glm::vec2> pts, std::vector<std::vector<int>> paths)
        : pts_(std::move(pts)), paths_(std::move(paths)) {
        lo_ = hi_ = pts_.front();
        for (const auto& q : pts_) {
            lo_ = glm::min(lo_, q);
            hi_ = glm::max(hi_, q);
        }
    }
    float eval(glm::vec2 p) const {
        float best = kInf;
        bool inside = false;
        for (const auto& path : paths_)
            for (std::size_t i = 0, j = path.size() - 1; i < path.size(); j = i++) {
                const glm::vec2 a = pts_[static_cast<std::size_t>(path[j])],
                                b = pts_[static_cast<std::size_t>(path[i])];
                const glm::vec2 e = b - a, w = p - a;
                const float t = glm::clamp(glm::dot(w, e) / std::max(glm::dot(e, e), 1e-30f), 0.f, 1.f);
                const glm::vec2 d = w - e * t;
                best = std::min(best, glm::dot(d, d));
                if ((a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) * e.x / e.y) inside = !inside;  // even-odd
            }
        return inside ? -std::sqrt(best) : std::sqrt(best);
    }
    std::pair<glm::vec2, glm::vec2> extent() const { return {lo_, hi_}; }
    std::string describe() const override { return "polygon(" + std::to_string(pts_.size()) + " points)"; }

private:
    std::vector<glm::vec2> pts_;
    std::vector<std::vector<int>> paths_;
    glm::vec2 lo_, hi_;
};

class LinearExtrude final : public implicit::Field {
public:
    LinearExtrude(FieldPtr c, float h, bool center, float twistDeg, glm::vec2 scale)
        : child_(std::move(c)),
          z0_(center ? -0.5f * h : 0.f),
          h_(h),
          twist_(static_cast<float>(twistDeg * M_PI / 180.0)),
          scale_(scale) {
        const Box3 cb = child_->bounds();
        const float r = glm::length(glm::max(glm::abs(glm::vec2(cb.min)), glm::abs(glm::vec2(cb.max))));
        radius_ = std::isfinite(r) ? r * std::max({1.f, scale.x, scale.y}) : kInf;
        plain_ = twist_ == 0.f && scale_ == glm::vec2(1.f);
        // The map (x, y, z) -> 2D point moves by at most radius * |twist| / h + |scale - 1| * radius / h
        // per unit of z, so dividing the value by this Lipschitz factor keeps it a lower bound of the distance.
        lipschitz_ = plain_ ? 1.f
                            : 1.f + (std::abs(twist_) + std::max(std::abs(scale.x - 1.f), std::abs(scale.y - 1.f))) *
                                        radius_ / h_;
    }
    float value(const glm::vec3& p) const override {
        float d2;
        if (plain_) {
            d2 = child_->value(glm::vec3(p.x, p.y, 0.f));
        } else {
            // OpenSCAD: at height t in [0, 1] the profile is scaled by lerp(1, scale, t) and turned by
            // -twist * t (a positive twist turns clockwise seen from +z).
            const float t = glm::clamp((p.z - z0_) / h_, 0.f, 1.f);
            const float a = twist_ * t, c = std::cos(a), s = std::sin(a);
            const glm::vec2 q(c * p.x - s * p.y, s * p.x + c * p.y);  // undo the rotation by -a
            const glm::vec2 sc = glm::max(glm::mix(glm::vec2(1.f), scale_, t), glm::vec2(1e-6f));
            d2 = child_->value(glm::vec3(q.x / sc.x, q.y / sc.y, 0.f)) * std::min(sc.x, sc.y) / lipschitz_;
        }
        const glm::vec2 w(d2, std::abs(p.z - z0_ - 0.5f * h_) - 0.5f * h_);
        return std::min(std::max(w.x, w.y), 0.f) + glm::length(glm::max(w, glm::vec2(0.f)));
    }
    Interval bound(const Box3& b) const override {
        // The extrusion of a distance is 1-Lipschitz when the 2D field is (and the twisted or
        // scaled profile is divided by its Lipschitz factor).
        return implicit::lipschitz(value(b.centre()), 1.f, b.halfDiagonal());
    }
    Box3 bounds() const override {
        Box3 b = child_->bounds();
        if (!plain_) {
            b.min = glm::vec3(-radius_);
            b.max = glm::vec3(radius_);
        }
        b.min.z = z0_;
        b.max.z = z0_ + h_;
        return b;
    }
    std::string describe() const override { return "linear_extrude(" + child_->describe() + ")"; }
    const implicit::Material* materialAt(const glm::vec3& p) const override { return child_->materialAt(p); }
    bool hasMaterial() const override { return child_->hasMaterial(); }
    bool translucent(bool inherited) const override { return child_->translucent(inherited); }

private:
    FieldPtr child_;
    float z0_, h_, twist_;
    glm::vec2 scale_;
    float radius_ = kInf, lipschitz_ = 1.f;
    bool plain_ = true;
};

/// A regular n-gon of circumradius r, its first vertex at angle `phase` from +x: the signed distance
/// to the edge of the point's own sector (exact inside, a lower bound outside), in O(1) whatever n.
class RegularPolygon2D final : public Shape2D<RegularPolygon2D> {
public:
    RegularPolygon2D(float r, int n, double phase)
        : r_(r),
          n_(n),
          step_(2.0 * M_PI / n),
          phase_(phase),
          apothem_(r * std::cos(M_PI / n)),
          sectors_(n, step_, phase, true) {}
    float eval(glm::vec2 p) const { return static_cast<float>(sectors_.support(p.x, p.y) - apothem_); }
    /// The box of the vertices: exact (resize() and bounding boxes depend on it).
    std::pair<glm::vec2, glm::vec2> extent() const {
        glm::vec2 lo(r_), hi(-r_);
        for (int j = 0; j < n_; ++j) {
            const double a = phase_ + j * step_;
            const glm::vec2 q(float(r_ * std::cos(a)), float(r_ * std::sin(a)));
            lo = glm::min(lo, q);
            hi = glm::max(hi, q);
        }
        return {lo, hi};
    }
    std::string describe() const override { return "circle($fn=" + std::to_string(n_) + ")"; }

private:
    float r_;
    int n_;
    double step_, phase_, apothem_;
    Sectors sectors_;
};

/// A 2D child (its x >= 0 side, or its mirror image for profiles on the x <= 0 side) revolved about
/// the z axis, smoothly or as OpenSCAD facets it: `segments` flat segments, each of the angle's
/// 1/segments, the first from the +x axis. Faceted, a point at radius rho whose angle lies `delta`
/// off the middle of its segment sees the profile at r' = rho cos(delta) / cos(half the segment's
/// angle): the facets between two profile points are the trapezoids on which r' runs along the
/// profile's edge, so the zero set is exactly OpenSCAD's. The value is scaled by cos(half angle)
/// to stay a lower bound of the distance.
class RotateExtrude final : public implicit::Field {
public:
    RotateExtrude(FieldPtr c, float angleDeg, int segments, bool mirrored) : child_(std::move(c)), mirror_(mirrored) {
        const Box3 cb = child_->bounds();
        const float size = std::max(cb.max.x - cb.min.x, cb.max.y - cb.min.y);
        axisOffset_ = std::isfinite(size) ? 1e-6f * size : 0.f;
        const double a = std::clamp(double(angleDeg), -360.0, 360.0) * M_PI / 180.0;
        full_ = std::abs(angleDeg) >= 360.f;
        // The wedge from the +x axis turning counter-clockwise by `a` (clockwise when negative).
        lo_ = static_cast<float>(std::min(0.0, a));
        hi_ = static_cast<float>(std::max(0.0, a));
        if (segments > 0) {
            step_ = std::abs(full_ ? 2.0 * M_PI : a) / segments;
            if (step_ < 0.9 * M_PI) {  // one segment over half a turn or more has no faceted meaning
                cosHalf_ = std::cos(0.5 * step_);
                faceted_ = true;
                sectors_.emplace(segments, step_, double(lo_), full_);
            }
        }
    }
    float value(const glm::vec3& q) const override {
        // A profile on the -x side sweeps the half-turn opposite: query the point turned by 180 degrees.
        const glm::vec3 p = mirror_ ? glm::vec3(-q.x, -q.y, q.z) : q;
        const float inPlane = profile(p);
        if (full_) return inPlane;
        float phi = std::atan2(p.y, p.x);
        if (phi < lo_) phi += 2.f * static_cast<float>(M_PI);
        if (phi > hi_ && phi - 2.f * static_cast<float>(M_PI) >= lo_) phi -= 2.f * static_cast<float>(M_PI);
        if (phi >= lo_ && phi <= hi_) {
            // Inside the wedge: the revolved profile, capped by the two end planes.
            const float toEnd = std::min(capDistance(p, lo_), capDistance(p, hi_));
            return inPlane < 0 ? std::max(inPlane, -toEnd) : inPlane;
        }
        // Outside the wedge: the nearer of the two end faces (the profile placed in each end half-plane).
        auto toCap = [&](float ang) {
            const glm::vec2 dir(std::cos(ang), std::sin(ang));
            const float u = p.x * dir.x + p.y * dir.y;   // along the end half-plane
            const float v = -p.x * dir.y + p.y * dir.x;  // across it
            const float in = std::max(child(u, p.z), 0.f);
            return std::sqrt(v * v + in * in);
        };
        return std::min(toCap(lo_), toCap(hi_));
    }
    Interval bound(const Box3& b) const override {
        return implicit::lipschitz(value(b.centre()), 1.f, b.halfDiagonal());
    }
    Box3 bounds() const override {
        const Box3 c = child_->bounds();
        const float r = std::max(std::abs(c.min.x), std::abs(c.max.x));
        if (!faceted_ || !full_ || !std::isfinite(r)) return {glm::vec3(-r, -r, c.min.y), glm::vec3(r, r, c.max.y)};
        // Faceted: the farthest profile point traces a polygon whose vertices give the box exactly.
        glm::vec2 lo(r), hi(-r);
        const int n = static_cast<int>(std::lround(2.0 * M_PI / step_));
        for (int j = 0; j < n; ++j) {
            const float flip = mirror_ ? -1.f : 1.f;
            const glm::vec2 q(flip * float(r * std::cos(j * step_)), flip * float(r * std::sin(j * step_)));
            lo = glm::min(lo, q);
            hi = glm::max(hi, q);
        }
        return {glm::vec3(lo, c.min.y), glm::vec3(hi, c.max.y)};
    }
    std::string describe() const override { return "rotate_extrude(" + child_->describe() + ")"; }
    const implicit::Material* materialAt(const glm::vec3& p) const override { return child_->materialAt(p); }
    bool hasMaterial() const override { return child_->hasMaterial(); }
    bool translucent(bool inherited) const override { return child_->translucent(inherited); }

private:
    /// The profile at radius r. Points on the axis are taken a hair off it: a profile that touches
    /// the axis has its edge there, where the 2D sign is a coin toss, while in 3D the axis is inside.
    float child(float r, float z) const {
        r = std::max(r, axisOffset_);
        return child_->value(glm::vec3(mirror_ ? -r : r, z, 0.f));  // the profile's own side
    }
    /// The profile's value at the point's radius (smooth) or at its faceted radius r'.
    float profile(const glm::vec3& p) const {
        if (!faceted_) return child(std::sqrt(p.x * p.x + p.y * p.y), p.z);
        const double along = sectors_->support(p.x, p.y);
        return static_cast<float>(child(static_cast<float>(std::max(along, 0.0) / cosHalf_), p.z) * cosHalf_);
    }
    /// Distance from p to the end half-plane at angle `ang` (for points inside the wedge).
    static float capDistance(const glm::vec3& p, float ang) {
        const glm::vec2 dir(std::cos(ang), std::sin(ang));
        const float u = p.x * dir.x + p.y * dir.y, v = -p.x * dir.y + p.y * dir.x;
        return u >= 0 ? std::abs(v) : std::sqrt(u * u + v * v);
    }
    FieldPtr child_;
    bool mirror_ = false, full_ = true, faceted_ = false;
    float lo_ = 0.f, hi_ = 0.f;
    double step_ = 0, cosHalf_ = 1;
    std::optional<Sectors> sectors_;  // faceted: the segments
    float axisOffset_ = 0.f;
};

}  // namespace

FieldPtr makeCircle2D(float r) {
    if (!(r > 0)) throw std::invalid_argument("circle: radius must be positive");
    return std::make_shared<Circle2D>(r);
}
FieldPtr makeRectangle2D(glm::vec2 lo, glm::vec2 hi) {
    if (!(hi.x > lo.x && hi.y > lo.y)) throw std::invalid_argument("square: sizes must be positive");
    return std::make_shared<Rectangle2D>(lo, hi);
}
FieldPtr makePolygon2D(std::vector<glm::vec2> points, std::vector<std::vector<int>> paths) {
    if (points.size() < 3) throw std::invalid_argument("polygon: needs at least 3 points");
    if (paths.empty()) {
        paths.emplace_back();
        for (std::size_t i = 0; i < points.size(); ++i) paths.back().push_back(static_cast<int>(i));
    }
    for (const auto& path : paths)
        for (int i : path)
            if (i < 0 || static_cast<std::size_t>(i) >= points.size())
                throw std::invalid_argument("polygon: a path names point " + std::to_string(i) + ", but there are " +
                                            std::to_string(points.size()));
    return std::make_shared<Polygon2D>(std::move(points), std::move(paths));
}
FieldPtr makeLinearExtrude(FieldPtr c, float h, bool center, float twistDeg, glm::vec2 scale) {
    if (!(h > 0)) throw std::invalid_argument("linear_extrude: height must be positive");
    if (!(scale.x >= 0 && scale.y >= 0)) throw std::invalid_argument("linear_extrude: scale must not be negative");
    if (!std::isfinite(twistDeg)) throw std::invalid_argument("linear_extrude: twist must be finite");
    return std::make_shared<LinearExtrude>(std::move(c), h, center, twistDeg, scale);
}
FieldPtr makeRegularPolygon2D(float r, int n, double phase) {
    if (!(r > 0) || !std::isfinite(r) || n < 3)
        throw std::invalid_argument("circle: radius must be positive, $fn >= 3");
    return std::make_shared<RegularPolygon2D>(r, n, phase);
}
FieldPtr makeRotateExtrude(FieldPtr c, float angleDeg, int segments, bool mirrored) {
    if (!(angleDeg != 0.f) || !std::isfinite(angleDeg))
        throw std::invalid_argument("rotate_extrude: angle must be non-zero and finite");
    return std::make_shared<RotateExtrude>(std::move(c), angleDeg, segments, mirrored);
}

FieldPtr makeFacetedSphere(float r, int n) {
    if (!(r > 0) || n < 3) throw std::invalid_argument("sphere: radius must be positive and $fn >= 3");
    // OpenSCAD: (n + 1) / 2 rings at polar angles 180 (i + 0.5) / rings, each a regular n-gon, joined
    // by flat quads at the same angles; the end rings are flat caps. That is the faceted revolve of
    // the profile through the rings' radii closed along the axis, which is half of a regular polygon
    // of 2 rings sides with its first vertex half a step off the +z axis: O(1) per point.
    const int rings = (n + 1) / 2;
    return makeRotateExtrude(makeRegularPolygon2D(r, 2 * rings, M_PI / 2 - M_PI / (2 * rings)), 360.f, n);
}

FieldPtr makeFacetedCylinder(float r1, float r2, float h, bool center, int n) {
    if (!(h > 0) || r1 < 0 || r2 < 0 || r1 + r2 <= 0 || n < 3)
        throw std::invalid_argument("cylinder: height must be positive, radii non-negative (not both 0), $fn >= 3");
    const float z0 = center ? -0.5f * h : 0.f;
    if (r1 == r2)  // a prism: the regular polygon extruded (exact distance along z)
        return makeLinearExtrude(makeRegularPolygon2D(r1, n), h, center);
    std::vector<glm::vec2> profile{{0.f, z0}, {r1, z0}, {r2, z0 + h}, {0.f, z0 + h}};
    if (r1 == 0) profile.erase(profile.begin() + 1);
    if (r2 == 0) profile.erase(profile.end() - 2);
    return makeRotateExtrude(makePolygon2D(std::move(profile)), 360.f, n);
}

}  // namespace isoforge::csg
