#include "implicit/primitives.h"

#include "implicit/box_distance.h"
#include "implicit/box_union.h"
#include "implicit/scratch.h"

#include <array>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

namespace isoforge::implicit {

namespace {

std::string fmt(const char* name, std::initializer_list<std::pair<const char*, float>> args) {
    std::ostringstream s;
    s << name << "(";
    bool first = true;
    for (auto [k, v] : args) {
        s << (first ? "" : ", ") << k << "=" << v;
        first = false;
    }
    s << ")";
    return s.str();
}

/// A primitive distance field: the derived class gives eval(p); batch evaluation is one tight
/// loop, the bound follows from 1-Lipschitz continuity.
template <class Derived>
class Primitive : public Field {
public:
    float value(const glm::vec3& p) const override { return self().eval(p); }
    void values(std::span<const glm::vec3> p, std::span<float> out) const override {
        for (std::size_t i = 0; i < p.size(); ++i) out[i] = self().eval(p[i]);
    }
    Interval bound(const Box3& box) const override {
        return lipschitz(self().eval(box.centre()), 1.f, box.halfDiagonal());
    }

private:
    const Derived& self() const { return static_cast<const Derived&>(*this); }
};

/// The exact range over a box of a field that grows with each |p_k| (a sphere's or a centred box's
/// distance): its values at the point of the box nearest the origin on every axis and at the one
/// farthest from it. eval rounds monotonically (abs, +, *, sqrt, min, max), so no point of the box
/// gives less or more. Far tighter than the Lipschitz bound, so pruning keeps fewer boxes (a block
/// of a Menger sponge kept a hundred of its bars).
template <class F>
Interval boundBySymmetry(const Box3& b, const F& eval) {
    glm::vec3 nearest, farthest;
    for (int k = 0; k < 3; ++k) {
        const float lo = b.min[k], hi = b.max[k];
        nearest[k] = lo > 0.f ? lo : (hi < 0.f ? -hi : 0.f);
        farthest[k] = std::max(std::abs(lo), std::abs(hi));
    }
    return {eval(nearest), eval(farthest)};
}

class Sphere final : public Primitive<Sphere> {
public:
    explicit Sphere(float r) : r_(r) {}
    float eval(const glm::vec3& p) const { return glm::length(p) - r_; }
    Interval bound(const Box3& b) const override {
        if (b.isEmpty()) return Primitive::bound(b);
        return boundBySymmetry(b, [this](const glm::vec3& p) { return eval(p); });
    }
    glm::vec3 gradient(const glm::vec3& p) const override {
        const float l = glm::length(p);
        return l > 0 ? p / l : glm::vec3(0, 0, 1);
    }
    bool cheapGradient() const override { return true; }
    bool valueFirst() const override { return true; }
    Box3 bounds() const override { return {glm::vec3(-r_), glm::vec3(r_)}; }
    std::string describe() const override { return fmt("sphere", {{"r", r_}}); }

private:
    float r_;
};

class Plane final : public Primitive<Plane> {
public:
    Plane(glm::vec3 n, float d) {
        const float l = glm::length(n);
        if (!(l > 0)) throw std::invalid_argument("plane: the normal must not be zero");
        n_ = n / l;
        d_ = d / l;
    }
    float eval(const glm::vec3& p) const { return glm::dot(n_, p) - d_; }
    Interval bound(const Box3& b) const override {
        Interval s(-d_);
        for (int k = 0; k < 3; ++k) s = s + Interval(b.min[k], b.max[k]) * Interval(n_[k]);
        return s;
    }
    glm::vec3 gradient(const glm::vec3&) const override { return n_; }
    bool cheapGradient() const override { return true; }
    bool valueFirst() const override { return true; }
    Box3 bounds() const override { return Box3::everything(); }
    std::string describe() const override {
        return fmt("plane", {{"nx", n_.x}, {"ny", n_.y}, {"nz", n_.z}, {"d", d_}});
    }

private:
    glm::vec3 n_;
    float d_;
};

class Box final : public Primitive<Box> {
public:
    Box(glm::vec3 size, float rounding) : half_(0.5f * size - glm::vec3(rounding)), r_(rounding), size_(size) {
        if (!(size.x > 0 && size.y > 0 && size.z > 0)) throw std::invalid_argument("box: sizes must be positive");
        if (rounding < 0 || glm::any(glm::lessThan(half_, glm::vec3(0.f))))
            throw std::invalid_argument("box: rounding must be between 0 and half the smallest size");
    }
    float eval(const glm::vec3& p) const { return boxDistance(p, half_) - r_; }
    Interval bound(const Box3& b) const override {
        if (b.isEmpty()) return Primitive::bound(b);
        return boundBySymmetry(b, [this](const glm::vec3& p) { return eval(p); });
    }
    bool cheapGradient() const override { return true; }
    bool valueFirst() const override { return true; }
    /// Exact on either side of an edge: outside, towards the nearest point; inside, the nearest face's normal.
    glm::vec3 gradient(const glm::vec3& p) const override {
        glm::vec3 g(0.f);
        valueAndGradient(p, g);
        return g;
    }
    /// eval(p) and gradient(p) from one q = |p| - half (the same arithmetic as boxDistance).
    float valueAndGradient(const glm::vec3& p, glm::vec3& g) const override {
        return boxValueAndGradient(p, half_, r_, g);
    }
    bool asBoxes(const FieldPtr& self, std::vector<BoxTerm>& out) const override {
        out.push_back({self, half_, r_, {}});
        return true;
    }
    Box3 bounds() const override { return {-0.5f * size_, 0.5f * size_}; }
    std::string describe() const override {
        return r_ > 0 ? fmt("box", {{"x", size_.x}, {"y", size_.y}, {"z", size_.z}, {"r", r_}})
                      : fmt("box", {{"x", size_.x}, {"y", size_.y}, {"z", size_.z}});
    }

private:
    glm::vec3 half_;
    float r_;
    glm::vec3 size_;
};

class Cylinder final : public Primitive<Cylinder> {
public:
    Cylinder(float r, float h) : r_(r), h_(0.5f * h) {
        if (!(r > 0 && h > 0)) throw std::invalid_argument("cylinder: radius and height must be positive");
    }
    float eval(const glm::vec3& p) const {
        const glm::vec2 d(std::sqrt(p.x * p.x + p.y * p.y) - r_, std::abs(p.z) - h_);
        return std::min(std::max(d.x, d.y), 0.f) + glm::length(glm::max(d, glm::vec2(0.f)));
    }
    Box3 bounds() const override { return {glm::vec3(-r_, -r_, -h_), glm::vec3(r_, r_, h_)}; }
    std::string describe() const override { return fmt("cylinder", {{"r", r_}, {"h", 2 * h_}}); }

private:
    float r_, h_;
};

/// Capped cone (frustum) along z: exact distance in the (radial, z) half-plane to the trapezoid.
class Cone final : public Primitive<Cone> {
public:
    Cone(float r1, float r2, float h) : r1_(r1), r2_(r2), h_(0.5f * h) {
        if (!(r1 >= 0 && r2 >= 0 && r1 + r2 > 0 && h > 0))
            throw std::invalid_argument("cone: radii must be non-negative (not both zero), height positive");
    }
    float eval(const glm::vec3& p) const {
        const glm::vec2 q(std::sqrt(p.x * p.x + p.y * p.y), p.z);
        // Distance to the caps (horizontal segments) and to the slanted side segment.
        const glm::vec2 cap(q.x - std::min(q.x, q.y < 0 ? r1_ : r2_), std::abs(q.y) - h_);
        const glm::vec2 a(r1_, -h_), b(r2_, h_), ab = b - a;
        const float t = glm::clamp(glm::dot(q - a, ab) / glm::dot(ab, ab), 0.f, 1.f);
        const glm::vec2 side = q - (a + t * ab);
        // Inside: on the axis side of the slanted line (left of a -> b) and between the caps.
        const float cross = ab.x * (q.y - a.y) - ab.y * (q.x - a.x);
        const bool inside = cross > 0 && std::abs(q.y) < h_;
        const float d = std::sqrt(std::min(glm::dot(cap, cap), glm::dot(side, side)));
        return inside ? -d : d;
    }
    Box3 bounds() const override {
        const float r = std::max(r1_, r2_);
        return {glm::vec3(-r, -r, -h_), glm::vec3(r, r, h_)};
    }
    std::string describe() const override { return fmt("cone", {{"r1", r1_}, {"r2", r2_}, {"h", 2 * h_}}); }

private:
    float r1_, r2_, h_;
};

class Torus final : public Primitive<Torus> {
public:
    Torus(float R, float r) : R_(R), r_(r) {
        if (!(R > 0 && r > 0)) throw std::invalid_argument("torus: radii must be positive");
    }
    float eval(const glm::vec3& p) const {
        const float q = std::sqrt(p.x * p.x + p.y * p.y) - R_;
        return std::sqrt(q * q + p.z * p.z) - r_;
    }
    Box3 bounds() const override {
        const float e = R_ + r_;
        return {glm::vec3(-e, -e, -r_), glm::vec3(e, e, r_)};
    }
    std::string describe() const override { return fmt("torus", {{"R", R_}, {"r", r_}}); }

private:
    float R_, r_;
};

class Capsule final : public Primitive<Capsule> {
public:
    Capsule(float r, float h) : r_(r), h_(0.5f * h) {
        if (!(r > 0 && h >= 0)) throw std::invalid_argument("capsule: radius must be positive, height non-negative");
    }
    float eval(const glm::vec3& p) const {
        return glm::length(glm::vec3(p.x, p.y, p.z - glm::clamp(p.z, -h_, h_))) - r_;
    }
    Box3 bounds() const override { return {glm::vec3(-r_, -r_, -h_ - r_), glm::vec3(r_, r_, h_ + r_)}; }
    std::string describe() const override { return fmt("capsule", {{"r", r_}, {"h", 2 * h_}}); }

private:
    float r_, h_;
};

float segmentDistance2(glm::vec3 p, glm::vec3 a, glm::vec3 b) {
    const glm::vec3 ab = b - a;
    const float t = glm::clamp(glm::dot(p - a, ab) / glm::dot(ab, ab), 0.f, 1.f);
    const glm::vec3 d = p - (a + t * ab);
    return glm::dot(d, d);
}

/// Regular tetrahedron: exact distance. Inside, the nearest face plane; outside, the nearest
/// point of the four triangles.
class Tetrahedron final : public Primitive<Tetrahedron> {
public:
    explicit Tetrahedron(float s) : s_(s) {
        if (!(s > 0)) throw std::invalid_argument("tetrahedron: size must be positive");
        v_ = {glm::vec3(s, s, s), glm::vec3(s, -s, -s), glm::vec3(-s, s, -s), glm::vec3(-s, -s, s)};
        for (int f = 0; f < 4; ++f) {
            // Face f is opposite vertex f; its normal points away from that vertex.
            const glm::vec3 a = v_[(f + 1) % 4], b = v_[(f + 2) % 4], c = v_[(f + 3) % 4];
            glm::vec3 n = glm::normalize(glm::cross(b - a, c - a));
            if (glm::dot(n, v_[f] - a) > 0) n = -n;
            n_[f] = n;
            d_[f] = glm::dot(n, a);
        }
    }
    float eval(const glm::vec3& p) const {
        float planes = -1e30f;
        for (int f = 0; f < 4; ++f) planes = std::max(planes, glm::dot(n_[f], p) - d_[f]);
        if (planes <= 0) return planes;
        float best = 1e30f;
        for (int f = 0; f < 4; ++f) {
            const glm::vec3 a = v_[(f + 1) % 4], b = v_[(f + 2) % 4], c = v_[(f + 3) % 4];
            // Inside the triangle's prism: distance to the plane; else to the nearest edge.
            const glm::vec3 n = n_[f];
            const float s1 = glm::dot(glm::cross(b - a, n), p - a), s2 = glm::dot(glm::cross(c - b, n), p - b),
                        s3 = glm::dot(glm::cross(a - c, n), p - c);
            const bool inPrism = (s1 <= 0 && s2 <= 0 && s3 <= 0) || (s1 >= 0 && s2 >= 0 && s3 >= 0);
            float d2;
            if (inPrism) {
                const float d = glm::dot(n, p) - d_[f];
                d2 = d * d;
            } else {
                d2 = std::min({segmentDistance2(p, a, b), segmentDistance2(p, b, c), segmentDistance2(p, c, a)});
            }
            best = std::min(best, d2);
        }
        return std::sqrt(best);
    }
    Box3 bounds() const override { return {glm::vec3(-s_), glm::vec3(s_)}; }
    std::string describe() const override { return fmt("tetrahedron", {{"size", s_}}); }

private:
    float s_;
    std::array<glm::vec3, 4> v_, n_;
    std::array<float, 4> d_;
};

/// Ellipsoid: (|p / r| - 1) * min(r). Its zero set is the exact ellipsoid; |value| never exceeds the
/// distance (p -> p / r is 1/min(r)-Lipschitz), so it is a conservative distance, exact on spheres.
class Ellipsoid final : public Primitive<Ellipsoid> {
public:
    explicit Ellipsoid(glm::vec3 r) : r_(r), m_(std::min({r.x, r.y, r.z})) {
        if (!(r.x > 0 && r.y > 0 && r.z > 0)) throw std::invalid_argument("ellipsoid: radii must be positive");
    }
    float eval(const glm::vec3& p) const { return (glm::length(p / r_) - 1.f) * m_; }
    Box3 bounds() const override { return {-r_, r_}; }
    std::string describe() const override { return fmt("ellipsoid", {{"a", r_.x}, {"b", r_.y}, {"c", r_.z}}); }

private:
    glm::vec3 r_;
    float m_;
};

/// Largest eigenvalue of a symmetric 3x3 matrix (closed form).
double largestEigenvalue(const glm::dmat3& a) {
    const double p1 = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    if (p1 < 1e-30) return std::max({a[0][0], a[1][1], a[2][2]});
    const double q = (a[0][0] + a[1][1] + a[2][2]) / 3.0;
    const double p2 =
        (a[0][0] - q) * (a[0][0] - q) + (a[1][1] - q) * (a[1][1] - q) + (a[2][2] - q) * (a[2][2] - q) + 2 * p1;
    const double p = std::sqrt(p2 / 6.0);
    const glm::dmat3 b = (1.0 / p) * (a - q * glm::dmat3(1.0));
    const double r = glm::clamp(glm::determinant(b) / 2.0, -1.0, 1.0);
    const double phi = std::acos(r) / 3.0;
    return q + 2 * p * std::cos(phi);
}

class Transformed final : public Field {
public:
    Transformed(FieldPtr child, const glm::mat4& m) : child_(std::move(child)), m_(m) {
        const glm::dmat3 l(m);
        if (!(std::abs(glm::determinant(l)) > 1e-12)) throw std::invalid_argument("transform: the matrix is singular");
        inv_ = glm::inverse(glm::dmat4(m));
        const glm::dmat3 li(inv_);
        // ||inverse||_2 = sqrt(largest eigenvalue of li^T li); distances scale by its reciprocal.
        scale_ = static_cast<float>(1.0 / std::sqrt(largestEigenvalue(glm::transpose(li) * li)));
        translation_ = li == glm::dmat3(1.0);
        shift_ = glm::vec3(inv_[3]);
    }
    /// The same transform of another child (a simplification of this one's).
    Transformed(FieldPtr child, const Transformed& like)
        : child_(std::move(child)),
          m_(like.m_),
          inv_(like.inv_),
          scale_(like.scale_),
          translation_(like.translation_),
          shift_(like.shift_) {}
    float value(const glm::vec3& p) const override { return child_->value(local(p)) * scale_; }
    void values(std::span<const glm::vec3> p, std::span<float> out) const override {
        // A scratch buffer of its nesting depth: a transform under a transform must not overwrite
        // the points its parent (or a boolean's next child) still reads.
        Scratch<glm::vec3> q(p.size());
        for (std::size_t i = 0; i < p.size(); ++i) q[i] = local(p[i]);
        child_->values(q.span(), out);
        for (float& v : out) v *= scale_;
    }
    Interval bound(const Box3& box) const override {
        const Interval c = child_->bound(localBox(box));
        return {c.lo * scale_, c.hi * scale_};
    }
    Box3 bounds() const override { return transformBox(child_->bounds(), glm::dmat4(m_)); }
    bool isDistance() const override { return child_->isDistance(); }
    FieldPtr simplify(const Box3& box) const override {
        FieldPtr c = child_->simplify(localBox(box));
        return c ? std::make_shared<Transformed>(c, *this) : nullptr;
    }
    Pruned prune(const Box3& box) const override {
        Pruned c = child_->prune(localBox(box));
        return {c.field ? std::make_shared<Transformed>(c.field, *this) : nullptr,
                {c.bound.lo * scale_, c.bound.hi * scale_}};
    }
    std::string describe() const override { return "transform(" + child_->describe() + ")"; }
    const implicit::Material* materialAt(const glm::vec3& p) const override { return child_->materialAt(local(p)); }
    glm::vec3 gradient(const glm::vec3& p) const override { return chain(child_->gradient(local(p))); }
    float valueAndGradient(const glm::vec3& p, glm::vec3& g) const override {
        const float v = child_->valueAndGradient(local(p), g);
        g = chain(g);
        return v * scale_;
    }
    bool cheapGradient() const override { return child_->cheapGradient(); }
    bool valueFirst() const override { return child_->valueFirst(); }
    /// A translation of boxes: each of them with this shift first (the same local points, bit for bit),
    /// unless one would then sit under more than kMaxBoxShifts translations.
    bool asBoxes(const FieldPtr&, std::vector<BoxTerm>& out) const override {
        if (!translation_ || scale_ != 1.f) return false;
        const std::size_t first = out.size();
        if (!child_->asBoxes(child_, out)) {
            out.resize(first);
            return false;
        }
        for (std::size_t i = first; i < out.size(); ++i)
            if (out[i].shifts.size() >= kMaxBoxShifts) {
                out.resize(first);
                return false;
            }
        for (std::size_t i = first; i < out.size(); ++i) {
            out[i].field = std::make_shared<Transformed>(out[i].field, *this);
            out[i].shifts.insert(out[i].shifts.begin(), shift_);
        }
        return true;
    }
    bool hasMaterial() const override { return child_->hasMaterial(); }
    bool translucent(bool inherited) const override { return child_->translucent(inherited); }

private:
    /// A translation (the most common transform) adds its float offset: the double product rounded
    /// to float is that sum, correctly rounded, so both give the same bits.
    glm::vec3 local(const glm::vec3& p) const {
        return translation_ ? p + shift_ : glm::vec3(inv_ * glm::dvec4(p, 1.0));
    }
    /// The chain rule: a child's gradient at local(p) to this field's, scale * (inverse's linear part)^T g.
    glm::vec3 chain(const glm::vec3& g) const {
        if (translation_) return g * scale_;  // the identity's product is g exactly
        return glm::vec3(glm::transpose(glm::dmat3(inv_)) * glm::dvec3(g)) * scale_;
    }
    Box3 localBox(const Box3& box) const {
        if (translation_ && !box.isEmpty()) return {box.min + shift_, box.max + shift_};
        return transformBox(box, inv_);
    }
    /// The box of the transformed box, by interval arithmetic per row (0 * infinity counts as 0,
    /// so that a 2D shape, infinite along z, keeps finite x and y bounds through a 2D transform).
    static Box3 transformBox(const Box3& b, const glm::dmat4& t) {
        if (b.isEmpty()) return b;
        Box3 out;
        for (int i = 0; i < 3; ++i) {
            double lo = t[3][i], hi = t[3][i];
            for (int j = 0; j < 3; ++j) {
                const double a = t[j][i];
                if (a == 0.0) continue;
                const double u = a * double(b.min[j]), v = a * double(b.max[j]);
                lo += std::min(u, v);
                hi += std::max(u, v);
            }
            out.min[i] = static_cast<float>(lo);
            out.max[i] = static_cast<float>(hi);
        }
        return out;
    }
    FieldPtr child_;
    glm::mat4 m_;
    glm::dmat4 inv_;
    float scale_;
    bool translation_ = false;  ///< the inverse's linear part is the identity
    glm::vec3 shift_{0.f};      ///< then its offset
};

class Offset final : public Field {
public:
    Offset(FieldPtr c, float r, bool shell) : child_(std::move(c)), r_(r), shell_(shell) {}
    float value(const glm::vec3& p) const override { return apply(child_->value(p)); }
    void values(std::span<const glm::vec3> p, std::span<float> out) const override {
        child_->values(p, out);
        for (float& v : out) v = apply(v);
    }
    Interval bound(const Box3& box) const override {
        const Interval c = child_->bound(box);
        return shell_ ? abs(c) - Interval(r_) : c - Interval(r_);
    }
    Box3 bounds() const override {
        const Box3 b = child_->bounds();
        return b.isBounded() ? b.expanded(std::max(r_, 0.f)) : b;
    }
    bool isDistance() const override { return child_->isDistance(); }
    FieldPtr simplify(const Box3& box) const override {
        FieldPtr c = child_->simplify(box);
        return c ? std::make_shared<Offset>(c, r_, shell_) : nullptr;
    }
    glm::vec3 gradient(const glm::vec3& p) const override {
        glm::vec3 g(0.f);
        valueAndGradient(p, g);
        return g;
    }
    float valueAndGradient(const glm::vec3& p, glm::vec3& g) const override {
        const float v = child_->valueAndGradient(p, g);
        if (shell_ && v < 0) g = -g;  // |v| turns the inside's gradient around
        return apply(v);
    }
    bool cheapGradient() const override { return child_->cheapGradient(); }
    bool valueFirst() const override { return child_->valueFirst(); }
    Pruned prune(const Box3& box) const override {
        const Pruned c = child_->prune(box);
        return {c.field ? std::make_shared<Offset>(c.field, r_, shell_) : nullptr,
                shell_ ? abs(c.bound) - Interval(r_) : c.bound - Interval(r_)};
    }
    std::string describe() const override {
        std::ostringstream s;
        s << (shell_ ? "shell(t=" : "offset(r=") << (shell_ ? 2 * r_ : r_) << ") " << child_->describe();
        return s.str();
    }

    const implicit::Material* materialAt(const glm::vec3& p) const override { return child_->materialAt(p); }
    bool hasMaterial() const override { return child_->hasMaterial(); }
    bool translucent(bool inherited) const override { return child_->translucent(inherited); }

private:
    float apply(float v) const { return (shell_ ? std::abs(v) : v) - r_; }
    FieldPtr child_;
    float r_;
    bool shell_;
};

class Clipped final : public Field {
public:
    Clipped(FieldPtr c, const Box3& b) : child_(std::move(c)), box_(b) {}
    float value(const glm::vec3& p) const override { return std::max(child_->value(p), boxValue(p)); }
    void values(std::span<const glm::vec3> p, std::span<float> out) const override {
        child_->values(p, out);
        for (std::size_t i = 0; i < p.size(); ++i) out[i] = std::max(out[i], boxValue(p[i]));
    }
    Interval bound(const Box3& b) const override {
        return max(child_->bound(b), lipschitz(boxValue(b.centre()), 1.f, b.halfDiagonal()));
    }
    Box3 bounds() const override { return child_->bounds().intersect(box_); }
    bool isDistance() const override { return child_->isDistance(); }
    FieldPtr simplify(const Box3& b) const override { return prune(b).field; }
    Pruned prune(const Box3& b) const override {
        const Pruned c = child_->prune(b);
        const Interval k = lipschitz(boxValue(b.centre()), 1.f, b.halfDiagonal());
        // Inside the box (with the region's own size to spare), the box term is never the max.
        if (k.hi < c.bound.lo) return {c.field ? c.field : child_, c.bound};
        return {c.field ? std::make_shared<Clipped>(c.field, box_) : nullptr, max(c.bound, k)};
    }
    std::string describe() const override { return child_->describe(); }
    const implicit::Material* materialAt(const glm::vec3& p) const override { return child_->materialAt(p); }
    bool hasMaterial() const override { return child_->hasMaterial(); }
    bool translucent(bool inherited) const override { return child_->translucent(inherited); }

private:
    float boxValue(const glm::vec3& p) const { return boxDistance(p - box_.centre(), 0.5f * box_.size()); }
    FieldPtr child_;
    Box3 box_;
};

}  // namespace

FieldPtr makeClipped(FieldPtr c, const Box3& b) {
    if (b.isEmpty() || !b.isBounded()) throw std::invalid_argument("clip box must be bounded and non-empty");
    return std::make_shared<Clipped>(std::move(c), b);
}

FieldPtr makeSphere(float r) {
    if (!(r > 0)) throw std::invalid_argument("sphere: radius must be positive");
    return std::make_shared<Sphere>(r);
}
FieldPtr makePlane(const glm::vec3& n, float d) {
    return std::make_shared<Plane>(n, d);
}
FieldPtr makeBox(const glm::vec3& size, float rounding) {
    return std::make_shared<Box>(size, rounding);
}
FieldPtr makeCylinder(float r, float h) {
    return std::make_shared<Cylinder>(r, h);
}
FieldPtr makeCone(float r1, float r2, float h) {
    return std::make_shared<Cone>(r1, r2, h);
}
FieldPtr makeTorus(float R, float r) {
    return std::make_shared<Torus>(R, r);
}
FieldPtr makeCapsule(float r, float h) {
    return std::make_shared<Capsule>(r, h);
}
FieldPtr makeTetrahedron(float s) {
    return std::make_shared<Tetrahedron>(s);
}
FieldPtr makeEllipsoid(const glm::vec3& r) {
    return std::make_shared<Ellipsoid>(r);
}
FieldPtr makeTransformed(FieldPtr c, const glm::mat4& m) {
    return std::make_shared<Transformed>(std::move(c), m);
}
FieldPtr makeTranslated(FieldPtr c, const glm::vec3& t) {
    glm::mat4 m(1.f);
    m[3] = glm::vec4(t, 1.f);
    return makeTransformed(std::move(c), m);
}
FieldPtr makeOffset(FieldPtr c, float r) {
    return std::make_shared<Offset>(std::move(c), r, false);
}
FieldPtr makeShell(FieldPtr c, float t) {
    if (!(t > 0)) throw std::invalid_argument("shell: thickness must be positive");
    return std::make_shared<Offset>(std::move(c), 0.5f * t, true);
}

}  // namespace isoforge::implicit
