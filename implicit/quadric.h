#pragma once
/// @file Quadric surfaces: A x^2 + B y^2 + C z^2 + D xy + E yz + F zx + G x + H y + I z + J = 0,
/// negative inside; compiled to a tape (batch evaluation, interval bounds). Most quadrics are
/// unbounded: clip them with a box. Not a distance.

#include <array>
#include <string>
#include <vector>

#include "implicit/field.h"

namespace isoforge::implicit {

/// The ten coefficients A..J above.
FieldPtr makeQuadric(const std::array<float, 10>& coefficients);

/// A standard quadric in canonical position, with semi-axes a, b, c where they apply:
/// ellipsoid, elliptic_cylinder, elliptic_cone, hyperboloid1 (one sheet), hyperboloid2 (two sheets),
/// elliptic_paraboloid, hyperbolic_paraboloid, parabolic_cylinder, hyperbolic_cylinder,
/// parallel_planes, intersecting_planes, sphere.
/// @throw std::invalid_argument naming the known types for an unknown one.
FieldPtr makeNamedQuadric(const std::string& type, float a = 1.f, float b = 1.f, float c = 1.f);
const std::vector<std::string>& quadricTypes();

}  // namespace isoforge::implicit
