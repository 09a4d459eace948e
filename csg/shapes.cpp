#include "csg/shapes.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

namespace isoforge::csg {

using implicit::Box3;
using implicit::Interval;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

/// Squared distance from p to triangle abc (closest point by regions, Ericson's method).
float triangleDistance2(const glm::vec3& p, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
    const glm::vec3 ab = b - a, ac = c - a, ap = p - a;
    const float d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    auto d2of = [&](const glm::vec3& q) { return glm::dot(p - q, p - q); };
    if (d1 <= 0 && d2 <= 0) return d2of(a);
    const glm::vec3 bp = p - b;
    const float d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return d2of(b);
    const float vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return d2of(a + ab * (d1 / (d1 - d3)));
    const glm::vec3 cp = p - c;
    const float d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return d2of(c);
    const float vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return d2of(a + ac * (d2 / (d2 - d6)));
    const float va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return d2of(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
    const float denom = 1.f / (va + vb + vc);
    return d2of(a + ab * (vb * denom) + ac * (vc * denom));
}

/// Solid angle of triangle abc seen from p (van Oosterom and Strackee).
double solidAngle(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    const double la = glm::length(a), lb = glm::length(b), lc = glm::length(c);
    const double num = glm::dot(a, glm::cross(b, c));
    const double den = la * lb * lc + glm::dot(a, b) * lc + glm::dot(b, c) * la + glm::dot(c, a) * lb;
    return 2.0 * std::atan2(num, den);
}

class Polyhedron final : public implicit::Field {
public:
    Polyhedron(std::vector<glm::vec3> pts, std::vector<glm::uvec3> tris) : p_(std::move(pts)), t_(std::move(tris)) {
        for (const auto& q : p_) box_ = box_.unite(Box3{q, q});
    }
    float value(const glm::vec3& q) const override {
        float best = kInf;
        double winding = 0;
        for (const auto& t : t_) {
            best = std::min(best, triangleDistance2(q, p_[t.x], p_[t.y], p_[t.z]));
            winding += solidAngle(glm::dvec3(p_[t.x] - q), glm::dvec3(p_[t.y] - q), glm::dvec3(p_[t.z] - q));
        }
        const float d = std::sqrt(best);
        return std::abs(winding) > 2.0 * M_PI ? -d : d;  // |winding number| > 1/2: inside
    }
    Interval bound(const Box3& b) const override {
        // 1-Lipschitz; far from the polyhedron, the distance to its box is a cheaper lower bound.
        const glm::vec3 c = b.centre();
        const glm::vec3 q = glm::clamp(c, box_.min, box_.max);
        const float toBox = glm::length(c - q) - b.halfDiagonal();
        if (toBox > 0) return {toBox, kInf};
        return implicit::lipschitz(value(c), 1.f, b.halfDiagonal());
    }
    Box3 bounds() const override { return box_; }
    std::string describe() const override { return "polyhedron(" + std::to_string(t_.size()) + " triangles)"; }

private:
    std::vector<glm::vec3> p_;
    std::vector<glm::uvec3> t_;
    Box3 box_;
};

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
    LinearExtrude(FieldPtr c, float h, bool center) : child_(std::move(c)), z0_(center ? -0.5f * h : 0.f), h_(h) {}
    float value(const glm::vec3& p) const override {
        const glm::vec2 w(child_->value(glm::vec3(p.x, p.y, 0.f)), std::abs(p.z - z0_ - 0.5f * h_) - 0.5f * h_);
        return std::min(std::max(w.x, w.y), 0.f) + glm::length(glm::max(w, glm::vec2(0.f)));
    }
    Interval bound(const Box3& b) const override {
        // The extrusion of a distance is 1-Lipschitz when the 2D field is.
        return implicit::lipschitz(value(b.centre()), 1.f, b.halfDiagonal());
    }
    Box3 bounds() const override {
        Box3 b = child_->bounds();
        b.min.z = z0_;
        b.max.z = z0_ + h_;
        return b;
    }
    std::string describe() const override { return "linear_extrude(" + child_->describe() + ")"; }
    glm::vec4 colorAt(const glm::vec3& p) const override { return child_->colorAt(p); }

private:
    FieldPtr child_;
    float z0_, h_;
};

class RotateExtrude final : public implicit::Field {
public:
    explicit RotateExtrude(FieldPtr c) : child_(std::move(c)) {}
    float value(const glm::vec3& p) const override {
        return child_->value(glm::vec3(std::sqrt(p.x * p.x + p.y * p.y), p.z, 0.f));
    }
    Interval bound(const Box3& b) const override {
        return implicit::lipschitz(value(b.centre()), 1.f, b.halfDiagonal());
    }
    Box3 bounds() const override {
        const Box3 c = child_->bounds();
        const float r = std::max(std::abs(c.min.x), std::abs(c.max.x));
        return {glm::vec3(-r, -r, c.min.y), glm::vec3(r, r, c.max.y)};
    }
    std::string describe() const override { return "rotate_extrude(" + child_->describe() + ")"; }
    glm::vec4 colorAt(const glm::vec3& p) const override { return child_->colorAt(p); }

private:
    FieldPtr child_;
};

}  // namespace

FieldPtr makePolyhedron(std::vector<glm::vec3> points, const std::vector<std::vector<int>>& faces) {
    if (faces.size() < 4) throw std::invalid_argument("polyhedron: a closed polyhedron needs at least 4 faces");
    std::vector<glm::uvec3> tris;
    for (std::size_t f = 0; f < faces.size(); ++f) {
        if (faces[f].size() < 3)
            throw std::invalid_argument("polyhedron: face " + std::to_string(f) + " has fewer than 3 points");
        for (int i : faces[f])
            if (i < 0 || static_cast<std::size_t>(i) >= points.size())
                throw std::invalid_argument("polyhedron: face " + std::to_string(f) + " names point " +
                                            std::to_string(i) + ", but there are " + std::to_string(points.size()));
        for (std::size_t k = 1; k + 1 < faces[f].size(); ++k) {
            const glm::vec3 a = points[static_cast<std::size_t>(faces[f][0])],
                            b = points[static_cast<std::size_t>(faces[f][k])],
                            c = points[static_cast<std::size_t>(faces[f][k + 1])];
            if (glm::length(glm::cross(b - a, c - a)) > 0.f)
                tris.emplace_back(faces[f][0], faces[f][k], faces[f][k + 1]);
        }
    }
    return std::make_shared<Polyhedron>(std::move(points), std::move(tris));
}

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
std::vector<glm::vec2> regularPolygon(float r, int n) {
    std::vector<glm::vec2> p;
    for (int i = 0; i < n; ++i) {
        const double a = 2.0 * M_PI * i / n;
        p.emplace_back(static_cast<float>(r * std::cos(a)), static_cast<float>(r * std::sin(a)));
    }
    return p;
}
FieldPtr makeLinearExtrude(FieldPtr c, float h, bool center) {
    if (!(h > 0)) throw std::invalid_argument("linear_extrude: height must be positive");
    return std::make_shared<LinearExtrude>(std::move(c), h, center);
}
FieldPtr makeRotateExtrude(FieldPtr c) {
    return std::make_shared<RotateExtrude>(std::move(c));
}

FieldPtr makeFacetedSphere(float r, int n) {
    if (!(r > 0) || n < 3) throw std::invalid_argument("sphere: radius must be positive and $fn >= 3");
    // OpenSCAD: (n + 1) / 2 rings at polar angles 180 (i + 0.5) / rings, each a regular n-gon.
    const int rings = (n + 1) / 2;
    std::vector<glm::vec3> pts;
    for (int i = 0; i < rings; ++i) {
        const double phi = M_PI * (i + 0.5) / rings;
        const double rr = r * std::sin(phi), z = r * std::cos(phi);
        for (const auto& q : regularPolygon(static_cast<float>(rr), n))
            pts.emplace_back(q.x, q.y, static_cast<float>(z));
    }
    std::vector<std::vector<int>> faces;
    std::vector<int> top, bottom;
    for (int j = 0; j < n; ++j) {
        top.push_back(j);
        bottom.push_back((rings - 1) * n + (n - 1 - j));
    }
    faces.push_back(top);
    faces.push_back(bottom);
    for (int i = 0; i + 1 < rings; ++i)
        for (int j = 0; j < n; ++j) {
            const int a = i * n + j, b = i * n + (j + 1) % n, c = (i + 1) * n + (j + 1) % n, d = (i + 1) * n + j;
            faces.push_back({a, b, c, d});
        }
    return makePolyhedron(std::move(pts), faces);
}

FieldPtr makeFacetedCylinder(float r1, float r2, float h, bool center, int n) {
    if (!(h > 0) || r1 < 0 || r2 < 0 || r1 + r2 <= 0 || n < 3)
        throw std::invalid_argument("cylinder: height must be positive, radii non-negative (not both 0), $fn >= 3");
    const float z0 = center ? -0.5f * h : 0.f;
    std::vector<glm::vec3> pts;
    for (const auto& q : regularPolygon(r1, n)) pts.emplace_back(q.x, q.y, z0);
    for (const auto& q : regularPolygon(r2, n)) pts.emplace_back(q.x, q.y, z0 + h);
    std::vector<std::vector<int>> faces;
    std::vector<int> bottom, top;
    for (int j = 0; j < n; ++j) {
        bottom.push_back(n - 1 - j);
        top.push_back(n + j);
    }
    faces.push_back(bottom);
    faces.push_back(top);
    for (int j = 0; j < n; ++j) faces.push_back({j, (j + 1) % n, n + (j + 1) % n, n + j});
    return makePolyhedron(std::move(pts), faces);
}

}  // namespace isoforge::csg
