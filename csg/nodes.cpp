#include "csg/nodes.h"

#include "implicit/box_union.h"
#include "implicit/scratch.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace isoforge::csg {

using implicit::Box3;
using implicit::Interval;
using implicit::Pruned;

namespace {

constexpr float kFar = 1e30f;

/// Polynomial smooth minimum of radius k (k > 0): equals min(a, b) when |a - b| >= k, and is at most
/// k / 4 below it.
inline float smin(float a, float b, float k) {
    const float h = std::max(k - std::abs(a - b), 0.f) / k;
    return std::min(a, b) - h * h * k * 0.25f;
}

class Boolean final : public implicit::Field {
public:
    Boolean(BoolOp op, std::vector<FieldPtr> c, float k) : op_(op), children_(std::move(c)), k_(k) {
        for (const auto& child : children_) {
            material_ = material_ || child->hasMaterial();
            cheap_ = cheap_ && child->cheapGradient();
            both_.push_back(child->cheapGradient() && !child->valueFirst());
        }
    }

    float value(const glm::vec3& p) const override {
        float v = children_[0]->value(p);
        for (std::size_t i = 1; i < children_.size(); ++i) v = combine(v, other(children_[i]->value(p)));
        return v;
    }
    void values(std::span<const glm::vec3> p, std::span<float> out) const override {
        children_[0]->values(p, out);
        implicit::Scratch<float> tmp(p.size());
        for (std::size_t i = 1; i < children_.size(); ++i) {
            children_[i]->values(p, tmp.span());
            for (std::size_t k = 0; k < p.size(); ++k) out[k] = combine(out[k], other(tmp[k]));
        }
    }
    Interval bound(const Box3& box) const override {
        Interval v = children_[0]->bound(box);
        for (std::size_t i = 1; i < children_.size(); ++i) {
            const Interval c = other(children_[i]->bound(box));
            v = isMin() ? implicit::min(v, c) : implicit::max(v, c);
        }
        // Smooth blends dip up to k/4 below the min (or above the max).
        if (k_ > 0) v = isMin() ? Interval(v.lo - 0.25f * k_, v.hi) : Interval(v.lo, v.hi + 0.25f * k_);
        return v;
    }
    Box3 bounds() const override {
        Box3 b = children_[0]->bounds();
        if (op_ == BoolOp::Union) {
            for (std::size_t i = 1; i < children_.size(); ++i) b = b.unite(children_[i]->bounds());
            if (k_ > 0 && b.isBounded()) b = b.expanded(k_);
        } else if (op_ == BoolOp::Intersection) {
            for (std::size_t i = 1; i < children_.size(); ++i) b = b.intersect(children_[i]->bounds());
        }
        return b;
    }
    bool isDistance() const override {
        for (const auto& c : children_)
            if (!c->isDistance()) return false;
        return true;
    }
    FieldPtr simplify(const Box3& box) const override { return prune(box).field; }
    Pruned prune(const Box3& box) const override {
        // Each child's simplification and bound over the box (transformed by the op, as in bound()).
        std::vector<Pruned> c(children_.size());
        for (std::size_t i = 0; i < children_.size(); ++i) {
            c[i] = children_[i]->prune(box);
            if (i > 0) c[i].bound = other(c[i].bound);
        }
        Interval v = c[0].bound;
        for (std::size_t i = 1; i < c.size(); ++i)
            v = isMin() ? implicit::min(v, c[i].bound) : implicit::max(v, c[i].bound);
        if (k_ > 0) v = isMin() ? Interval(v.lo - 0.25f * k_, v.hi) : Interval(v.lo, v.hi + 0.25f * k_);
        std::vector<std::size_t> keep;
        if (isMin()) {  // union: a child whose lowest value is above someone's highest (+ blend) never wins
            float best = kFar;
            for (const auto& i : c) best = std::min(best, i.bound.hi);
            for (std::size_t i = 0; i < c.size(); ++i)
                if (c[i].bound.lo <= best + k_) keep.push_back(i);
        } else {  // intersection / difference: a term below someone's lowest (- blend) never wins
            float best = -kFar;
            for (const auto& i : c) best = std::max(best, i.bound.lo);
            for (std::size_t i = 0; i < c.size(); ++i)
                if (c[i].bound.hi >= best - k_ || (op_ == BoolOp::Difference && i == 0)) keep.push_back(i);
        }
        bool changed = keep.size() != children_.size();
        std::vector<FieldPtr> kids;
        for (std::size_t i : keep) {
            changed = changed || c[i].field;
            kids.push_back(c[i].field ? c[i].field : children_[i]);
        }
        if (!changed) return {nullptr, v};
        if (kids.size() == 1 && (op_ != BoolOp::Difference || keep[0] == 0)) return {kids[0], v};
        if (op_ == BoolOp::Difference && keep[0] != 0) return {nullptr, v};  // the first child is always kept
        return {std::make_shared<Boolean>(op_, std::move(kids), k_), v};
    }
    std::string describe() const override {
        static const char* names[] = {"union", "intersection", "difference"};
        std::ostringstream s;
        s << (k_ > 0 ? "smooth_" : "") << names[static_cast<int>(op_)] << "(" << children_.size() << " children)";
        return s.str();
    }
    const implicit::Material* materialAt(const glm::vec3& p) const override {
        if (!material_) return nullptr;  // (without a colour below, no need to find the child)
        return children_[winner(p)]->materialAt(p);
    }
    bool hasMaterial() const override { return material_; }
    bool translucent(bool inherited) const override {
        return std::all_of(children_.begin(), children_.end(),
                           [&](const FieldPtr& c) { return c->translucent(inherited); });
    }
    /// The gradient of the child that decides the value (negated for a difference's subtrahends):
    /// exact on either side of a crease, where central differences would mix the two. Smooth blends
    /// take central differences.
    glm::vec3 gradient(const glm::vec3& p) const override {
        if (k_ > 0) return Field::gradient(p);
        glm::vec3 g(0.f);
        valueAndGradient(p, g);
        return g;
    }
    /// The children with cheap gradients (nested booleans of primitives) give theirs with their
    /// values; the others (and primitives, valueFirst) their values alone, and the deciding child its
    /// gradient afterwards (central differences or a primitive's gradient for one child, not all).
    float valueAndGradient(const glm::vec3& p, glm::vec3& g) const override {
        if (k_ > 0) {
            g = Field::gradient(p);
            return value(p);
        }
        std::size_t win = 0;
        bool known = false;
        float v = 0.f;
        for (std::size_t i = 0; i < children_.size(); ++i) {
            glm::vec3 gi(0.f);
            const bool cheap = both_[i];
            float c = cheap ? children_[i]->valueAndGradient(p, gi) : children_[i]->value(p);
            if (i > 0) c = other(c);
            if (i == 0 || (isMin() ? c < v : c > v)) {
                v = c;
                win = i;
                known = cheap;
                g = gi;
            }
        }
        if (!known) g = children_[win]->gradient(p);
        if (win > 0 && op_ == BoolOp::Difference) g = -g;
        return v;
    }
    bool cheapGradient() const override { return cheap_; }

private:
    bool isMin() const { return op_ == BoolOp::Union; }
    /// The child that decides the value at p (the first of equals).
    std::size_t winner(const glm::vec3& p) const {
        std::size_t win = 0;
        float v = children_[0]->value(p);
        for (std::size_t i = 1; i < children_.size(); ++i) {
            const float c = other(children_[i]->value(p));
            if (isMin() ? c < v : c > v) {
                v = c;
                win = i;
            }
        }
        return win;
    }
    float other(float v) const { return op_ == BoolOp::Difference ? -v : v; }
    Interval other(Interval v) const { return op_ == BoolOp::Difference ? -v : v; }
    float combine(float a, float b) const {
        if (k_ > 0) return isMin() ? smin(a, b, k_) : -smin(-a, -b, k_);
        return isMin() ? std::min(a, b) : std::max(a, b);
    }

    BoolOp op_;
    std::vector<FieldPtr> children_;
    float k_;
    bool material_ = false;
    bool cheap_ = k_ == 0;    ///< every child's gradient exact and cheap (cheapGradient)
    std::vector<char> both_;  ///< per child: ask for its value and gradient at once (else its value first)
};

class Colored final : public implicit::Field {
public:
    Colored(FieldPtr c, std::shared_ptr<const implicit::Material> m) : child_(std::move(c)), m_(std::move(m)) {}
    float value(const glm::vec3& p) const override { return child_->value(p); }
    void values(std::span<const glm::vec3> p, std::span<float> out) const override { child_->values(p, out); }
    Interval bound(const Box3& b) const override { return child_->bound(b); }
    Box3 bounds() const override { return child_->bounds(); }
    bool isDistance() const override { return child_->isDistance(); }
    FieldPtr simplify(const Box3& b) const override {
        FieldPtr s = child_->simplify(b);
        return s ? std::make_shared<Colored>(s, m_) : nullptr;
    }
    Pruned prune(const Box3& b) const override {
        Pruned c = child_->prune(b);
        if (c.field) c.field = std::make_shared<Colored>(c.field, m_);
        return c;
    }
    std::string describe() const override { return child_->describe(); }
    const implicit::Material* materialAt(const glm::vec3& p) const override {
        const implicit::Material* inner = child_->materialAt(p);
        return inner ? inner : m_.get();
    }
    bool hasMaterial() const override { return true; }
    bool translucent(bool) const override { return child_->translucent(m_->color.a < 1.f); }
    glm::vec3 gradient(const glm::vec3& p) const override { return child_->gradient(p); }
    float valueAndGradient(const glm::vec3& p, glm::vec3& g) const override { return child_->valueAndGradient(p, g); }
    bool cheapGradient() const override { return child_->cheapGradient(); }
    bool valueFirst() const override { return child_->valueFirst(); }

private:
    FieldPtr child_;
    std::shared_ptr<const implicit::Material> m_;
};

class Empty final : public implicit::Field {
public:
    float value(const glm::vec3&) const override { return kFar; }
    Interval bound(const Box3&) const override { return Interval(kFar); }
    Box3 bounds() const override { return Box3{}; }
    std::string describe() const override { return "empty"; }
};

}  // namespace

FieldPtr makeBoolean(BoolOp op, std::vector<FieldPtr> children, float blend) {
    if (children.empty()) throw std::invalid_argument("a boolean needs at least one child");
    if (!(blend >= 0.f)) throw std::invalid_argument("the blend radius must not be negative");
    // Runs of boxes under translations (OpenSCAD's cubes) become one union evaluated in a loop; the
    // values and gradients stay the same bits (implicit/box_union.h).
    if (blend == 0.f && op == BoolOp::Union) {
        children = implicit::groupBoxes(std::move(children));
    } else if (blend == 0.f && op == BoolOp::Difference && children.size() > 2) {
        std::vector<FieldPtr> rest = implicit::groupBoxes({children.begin() + 1, children.end()});
        rest.insert(rest.begin(), children[0]);
        children = std::move(rest);
    }
    if (children.size() == 1) return children[0];
    return std::make_shared<Boolean>(op, std::move(children), blend);
}

FieldPtr makeColored(FieldPtr child, const glm::vec4& rgba) {
    implicit::Material m;
    m.color = rgba;
    return makeMaterial(std::move(child), m);
}
FieldPtr makeMaterial(FieldPtr child, const implicit::Material& m) {
    return std::make_shared<Colored>(std::move(child), std::make_shared<const implicit::Material>(m));
}

FieldPtr makeEmpty() {
    return std::make_shared<Empty>();
}

}  // namespace isoforge::csg
