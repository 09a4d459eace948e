#pragma once
/// @file CSG trees as fields: union, intersection and difference (n-ary), their smooth versions with
/// a blend radius, and colour tags. Each node knows its bounds and prunes: over a region where a
/// child's bound proves it cannot change the result, simplify() drops it, with the same values.

#include <vector>

#include "implicit/field.h"

namespace isoforge::csg {

using implicit::FieldPtr;

enum class BoolOp { Union, Intersection, Difference };

/// n-ary boolean: union = min, intersection = max, difference = max(first, -rest...).
/// With blend > 0, the polynomial smooth min/max of radius `blend` (Quilez), applied pairwise.
/// @throw std::invalid_argument for no children or a negative blend.
FieldPtr makeBoolean(BoolOp op, std::vector<FieldPtr> children, float blend = 0.f);
inline FieldPtr makeUnion(std::vector<FieldPtr> c, float blend = 0.f) {
    return makeBoolean(BoolOp::Union, std::move(c), blend);
}
inline FieldPtr makeIntersection(std::vector<FieldPtr> c, float blend = 0.f) {
    return makeBoolean(BoolOp::Intersection, std::move(c), blend);
}
inline FieldPtr makeDifference(std::vector<FieldPtr> c, float blend = 0.f) {
    return makeBoolean(BoolOp::Difference, std::move(c), blend);
}

/// The child with a colour (RGBA, alpha > 0) for its surface; inner colours win over outer ones.
FieldPtr makeColored(FieldPtr child, const glm::vec4& rgba);
/// The child with a material (colour, opacity, Phong terms); inner materials win over outer ones.
FieldPtr makeMaterial(FieldPtr child, const implicit::Material& m);

/// A field that is empty everywhere (value +infinity-like), for empty groups.
FieldPtr makeEmpty();

}  // namespace isoforge::csg
