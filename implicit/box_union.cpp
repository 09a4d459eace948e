#include "implicit/box_union.h"

#include "implicit/box_distance.h"
#include "implicit/scratch.h"

#include <algorithm>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace isoforge::implicit {

namespace {

/// The boxes in columns (structure of arrays), so that a point's distances to all of them are a few
/// loops the compiler vectorises, where a tree of unions and translates made two virtual calls and a
/// scratch buffer per box. Terms with fewer translations than the deepest are padded with zero
/// shifts: p + 0 is p, bit for bit (a -0 becomes +0, which |p| and the sign test treat alike).
class BoxUnion final : public Field {
public:
    explicit BoxUnion(std::vector<BoxTerm> terms) : terms_(std::move(terms)) {
        if (terms_.size() < 2) throw std::invalid_argument("a union of boxes needs at least two boxes");
        const std::size_t n = terms_.size();
        for (const BoxTerm& t : terms_) depth_ = std::max(depth_, t.shifts.size());
        half_.resize(3 * n);
        rounding_.resize(n);
        shift_.assign(3 * n * depth_, 0.f);
        for (std::size_t i = 0; i < n; ++i) {
            const BoxTerm& t = terms_[i];
            for (int k = 0; k < 3; ++k) half_[std::size_t(k) * n + i] = t.half[k];
            rounding_[i] = t.rounding;
            for (std::size_t l = 0; l < t.shifts.size(); ++l)
                for (int k = 0; k < 3; ++k) shift_[(3 * l + std::size_t(k)) * n + i] = t.shifts[l][k];
        }
    }

    float value(const glm::vec3& p) const override {
        Scratch<float> scratch(4 * terms_.size());
        const float* d = distances(p, scratch.span().data());
        float v = d[0];
        for (std::size_t i = 1; i < terms_.size(); ++i) v = std::min(v, d[i]);
        return v;
    }
    void values(std::span<const glm::vec3> p, std::span<float> out) const override {
        Scratch<float> scratch(4 * terms_.size());
        for (std::size_t k = 0; k < p.size(); ++k) {
            const float* d = distances(p[k], scratch.span().data());
            float v = d[0];
            for (std::size_t i = 1; i < terms_.size(); ++i) v = std::min(v, d[i]);
            out[k] = v;
        }
    }
    Interval bound(const Box3& box) const override {
        Interval v = terms_[0].field->bound(box);
        for (std::size_t i = 1; i < terms_.size(); ++i) v = min(v, terms_[i].field->bound(box));
        return v;
    }
    Box3 bounds() const override {
        Box3 b = terms_[0].field->bounds();
        for (std::size_t i = 1; i < terms_.size(); ++i) b = b.unite(terms_[i].field->bounds());
        return b;
    }
    bool isDistance() const override { return true; }
    FieldPtr simplify(const Box3& box) const override { return prune(box).field; }
    /// A union's pruning: a box whose lowest value over the region is above some box's highest never decides.
    Pruned prune(const Box3& box) const override {
        std::vector<Interval> b(terms_.size());
        float best = std::numeric_limits<float>::infinity();
        for (std::size_t i = 0; i < terms_.size(); ++i) {
            b[i] = terms_[i].field->bound(box);
            best = std::min(best, b[i].hi);
        }
        Interval v = b[0];
        for (std::size_t i = 1; i < b.size(); ++i) v = min(v, b[i]);
        std::vector<BoxTerm> keep;
        for (std::size_t i = 0; i < terms_.size(); ++i)
            if (b[i].lo <= best) keep.push_back(terms_[i]);
        if (keep.size() == terms_.size()) return {nullptr, v};
        if (keep.size() == 1) return {keep[0].field, v};
        return {std::make_shared<BoxUnion>(std::move(keep)), v};
    }
    std::string describe() const override {
        std::ostringstream s;
        s << "union(" << terms_.size() << " boxes)";
        return s.str();
    }
    glm::vec3 gradient(const glm::vec3& p) const override {
        glm::vec3 g(0.f);
        valueAndGradient(p, g);
        return g;
    }
    /// The first box of the smallest value decides (as in a tree of unions), and gives its gradient.
    float valueAndGradient(const glm::vec3& p, glm::vec3& g) const override {
        Scratch<float> scratch(4 * terms_.size());
        const float* d = distances(p, scratch.span().data());
        std::size_t win = 0;
        for (std::size_t i = 1; i < terms_.size(); ++i)
            if (d[i] < d[win]) win = i;
        const float* x = d + terms_.size();  // the boxes' local points, as distances() left them
        const glm::vec3 q(x[win], x[terms_.size() + win], x[2 * terms_.size() + win]);
        boxValueAndGradient(q, terms_[win].half, terms_[win].rounding, g);
        return d[win];
    }
    bool cheapGradient() const override { return true; }
    bool asBoxes(const FieldPtr&, std::vector<BoxTerm>& out) const override {
        out.insert(out.end(), terms_.begin(), terms_.end());
        return true;
    }

private:
    /// Each box's value at p (boxDistance - rounding), in the first n floats of `scratch` (4n floats:
    /// the other 3n hold the boxes' local coordinates); returns them.
    const float* distances(const glm::vec3& p, float* scratch) const {
        const std::size_t n = terms_.size();
        float *d = scratch, *x = d + n, *y = x + n, *z = y + n;
        std::fill(x, x + n, p.x);
        std::fill(y, y + n, p.y);
        std::fill(z, z + n, p.z);
        for (std::size_t l = 0; l < depth_; ++l) {
            const float *sx = &shift_[3 * l * n], *sy = sx + n, *sz = sy + n;
            for (std::size_t i = 0; i < n; ++i) {
                x[i] += sx[i];
                y[i] += sy[i];
                z[i] += sz[i];
            }
        }
        const float *hx = half_.data(), *hy = hx + n, *hz = hy + n, *r = rounding_.data();
        for (std::size_t i = 0; i < n; ++i) d[i] = boxDistance(x[i], y[i], z[i], hx[i], hy[i], hz[i]) - r[i];
        return d;
    }

    std::vector<BoxTerm> terms_;
    std::size_t depth_ = 0;
    std::vector<float> half_;      ///< x halves of all boxes, then y, then z
    std::vector<float> rounding_;  ///< per box
    std::vector<float> shift_;     ///< per translation level: x shifts of all boxes, then y, then z
};

}  // namespace

FieldPtr makeBoxUnion(std::vector<BoxTerm> terms) {
    return std::make_shared<BoxUnion>(std::move(terms));
}

std::vector<FieldPtr> groupBoxes(std::vector<FieldPtr> children) {
    std::vector<FieldPtr> out;
    std::vector<BoxTerm> run;
    std::vector<FieldPtr> runFields;  // the run's children as they were, for a run of one
    auto flush = [&] {
        if (runFields.size() >= 2)
            out.push_back(makeBoxUnion(std::move(run)));
        else
            out.insert(out.end(), runFields.begin(), runFields.end());
        run.clear();
        runFields.clear();
    };
    for (FieldPtr& c : children) {
        if (c->asBoxes(c, run)) {
            runFields.push_back(std::move(c));
        } else {
            flush();
            out.push_back(std::move(c));
        }
    }
    flush();
    return out;
}

}  // namespace isoforge::implicit
