#pragma once
/// @file The Field interface: a function R^3 -> R, negative inside (the seed's convention, §3.6).

#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "implicit/interval.h"

namespace isoforge::implicit {

/// An axis-aligned box in world units; infinite components mean "unbounded".
struct Box3 {
    glm::vec3 min{std::numeric_limits<float>::infinity()};
    glm::vec3 max{-std::numeric_limits<float>::infinity()};
    static Box3 everything();
    bool isEmpty() const { return min.x > max.x || min.y > max.y || min.z > max.z; }
    bool isBounded() const;
    glm::vec3 centre() const { return 0.5f * (min + max); }
    glm::vec3 size() const { return max - min; }
    float halfDiagonal() const;
    Box3 intersect(const Box3& o) const;
    Box3 unite(const Box3& o) const;
    Box3 expanded(float r) const { return {min - glm::vec3(r), max + glm::vec3(r)}; }
};

/// How a surface looks: colour (alpha = opacity) and Phong terms. Attached to CSG subtrees by
/// `color()` and `material()`; carried to meshes as vertex colours and to the renderers.
struct Material {
    glm::vec4 color{0.8f, 0.8f, 0.8f, 1.f};
    float diffuse = 0.9f;    ///< Lambert weight
    float specular = 0.25f;  ///< Blinn-Phong highlight weight
    float shininess = 40.f;  ///< Blinn-Phong exponent
};

class Field;
using FieldPtr = std::shared_ptr<const Field>;
struct BoxTerm;  // implicit/box_union.h

/// A field's simplification over a box together with its bound there (Field::prune).
struct Pruned {
    FieldPtr field;  ///< simplify(box): nullptr when nothing can be dropped
    Interval bound;  ///< bound(box), the same with or without what was dropped
};

/// A scalar field, negative inside. Fields are immutable and shared between threads; evaluation
/// keeps no state in the field.
class Field {
public:
    virtual ~Field() = default;

    /// Value at a point (world units).
    virtual float value(const glm::vec3& p) const = 0;
    /// Values at many points: one tight loop per node, not one virtual call per point and node.
    virtual void values(std::span<const glm::vec3> p, std::span<float> out) const;
    /// Conservative bound of the values over a box: never narrower than the true range.
    virtual Interval bound(const Box3& box) const = 0;
    /// Where the surface and the inside can be (a box outside of which the field is positive);
    /// Box3::everything() for unbounded fields (planes, most quadrics, expressions).
    virtual Box3 bounds() const = 0;
    /// Gradient; central differences unless a field knows better.
    virtual glm::vec3 gradient(const glm::vec3& p) const;
    /// value(p), with gradient(p) in g: the same numbers, from one walk where a node can share the
    /// work (a min or max finds its deciding child once, a polyhedron its closest triangle once).
    virtual float valueAndGradient(const glm::vec3& p, glm::vec3& g) const;
    /// True when valueAndGradient costs about what value does (an exact gradient, no central
    /// differences): a boolean asks such children for both at once and the others for their values
    /// only, so that a gradient through nested booleans walks the tree once, not once per level.
    virtual bool cheapGradient() const { return false; }
    /// True for a primitive whose value alone costs clearly less than its value and gradient together
    /// (a box, a sphere, a plane, a polytope), also under transforms and colours: a boolean asks such
    /// children for their values only, and the one that decides for its gradient afterwards. The
    /// numbers are the same either way; most of a union's children do not decide.
    virtual bool valueFirst() const { return false; }
    /// A box, or boxes under translations and unions of them: appends them to `out` (self: this
    /// field's own pointer) and returns true, so that a union can evaluate them all in one loop
    /// (implicit/box_union.h); false, leaving `out` as it was, for anything else.
    virtual bool asBoxes(const FieldPtr& self, std::vector<BoxTerm>& out) const { return false; }
    /// True when |value| never exceeds the distance to the surface and the field is 1-Lipschitz,
    /// so that values are usable as (conservative) distances: sphere tracing, narrow bands.
    virtual bool isDistance() const { return true; }
    /// A bound on |gradient| everywhere (the field is L-Lipschitz), infinity where none is known:
    /// 1 for distance fields; a tape finds its own from its structure (implicit/lipschitz.cpp), so
    /// that a ray marcher can step by |value| / L where the field is no distance but has a bound.
    virtual float gradientBound() const { return isDistance() ? 1.f : std::numeric_limits<float>::infinity(); }
    /// A field equal to this one inside `box`, cheaper to evaluate there (CSG pruning, tape
    /// simplification, far blobs dropped); nullptr when nothing can be dropped.
    virtual FieldPtr simplify(const Box3& box) const { return nullptr; }
    /// simplify() and bound() over the same box, from one walk of the tree. Nodes with children
    /// (booleans, transforms, colours) override it: asking each child for its bound and then for
    /// its simplification walked a tree of nested groups once per level above each node.
    virtual Pruned prune(const Box3& box) const { return {simplify(box), bound(box)}; }
    /// A short description, e.g. "torus(R=1, r=0.3)".
    virtual std::string describe() const = 0;
    /// The material of the part of the surface nearest p, as CSG colour and material nodes
    /// assign it; nullptr where none is given. Owned by the field.
    virtual const Material* materialAt(const glm::vec3& p) const { return nullptr; }
    /// False when materialAt() is nullptr everywhere (no colour or material node anywhere in the
    /// tree), so that callers can skip asking it per vertex or triangle.
    virtual bool hasMaterial() const { return false; }
    /// True when every material materialAt() can give is translucent (alpha < 1), a point without a
    /// material of its own taking `inherited`'s (true: a translucent one): shadow rays pass through
    /// such a surface. Nodes that pass materialAt() on or pick among children forward it; the default
    /// is only sure where no material is given at all.
    virtual bool translucent(bool inherited) const { return inherited && !hasMaterial(); }
    /// The colour (RGBA) of materialAt(p); alpha 0 where no material is given.
    glm::vec4 colorAt(const glm::vec3& p) const {
        const Material* m = materialAt(p);
        return m ? m->color : glm::vec4(0.f);
    }
};

/// `f.simplify(box)` if it gives something, else `f` itself.
FieldPtr simplified(const FieldPtr& f, const Box3& box);

}  // namespace isoforge::implicit
