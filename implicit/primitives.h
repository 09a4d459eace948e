#pragma once
/// @file Primitive fields with exact signed distances (the ellipsoid's is a conservative
/// approximation), and the operators that keep distances valid: affine transforms, offset, shell.
/// Primitives are centred at the origin; the round ones have their axis along z.

#include <glm/mat4x4.hpp>

#include "implicit/field.h"

namespace isoforge::implicit {

FieldPtr makeSphere(float radius);
/// Half-space below the plane dot(normal, p) = offset (normal need not be unit length).
FieldPtr makePlane(const glm::vec3& normal, float offset);
FieldPtr makeBox(const glm::vec3& size, float rounding = 0.f);         ///< full edge lengths
FieldPtr makeCylinder(float radius, float height);                     ///< capped, centred
FieldPtr makeCone(float bottomRadius, float topRadius, float height);  ///< capped (frustum), centred
FieldPtr makeTorus(float majorRadius, float minorRadius);              ///< in the xy plane
FieldPtr makeCapsule(float radius, float height);                      ///< segment of length height
FieldPtr makeTetrahedron(float size);                                  ///< vertices (±s, ±s, ±s), even sign count
FieldPtr makeEllipsoid(const glm::vec3& radii);

/// child(inverse(m) * p), scaled so that distances stay conservative (exact for rigid motions
/// and uniform scales). @throw std::invalid_argument if m is singular.
FieldPtr makeTransformed(FieldPtr child, const glm::mat4& m);
FieldPtr makeTranslated(FieldPtr child, const glm::vec3& t);
/// Grows (r > 0) or shrinks the solid by r.
FieldPtr makeOffset(FieldPtr child, float r);
/// A hollow shell of thickness t centred on the surface.
FieldPtr makeShell(FieldPtr child, float thickness);
/// The intersection of a field with a box: max(child, box distance). Bounded by the box; the box
/// term is dropped in regions where it cannot matter.
FieldPtr makeClipped(FieldPtr child, const Box3& box);

}  // namespace isoforge::implicit
