#pragma once
/// @file One-line shape specifications for the command line: "torus(R=1, r=0.3)",
/// "box(2, 1, 0.5)", "quadric(type=hyperboloid1, a=1, b=1, c=0.5)". Arguments are named or
/// positional (in the documented order); omitted ones take defaults.

#include <string>
#include <string_view>

#include "implicit/field.h"

namespace isoforge::implicit {

/// @throw ParseError (with the column and what was expected) for malformed text, unknown shapes
/// or parameters, and invalid values.
FieldPtr parseShape(std::string_view spec);

/// The shapes and their parameters, for help texts.
std::string shapeHelp();

}  // namespace isoforge::implicit
