#pragma once
/// @file The union of many boxes under translations, evaluated box by box in one loop: what an
/// OpenSCAD model of cubes becomes (a Menger sponge's 220 bars under nested groups and translates).

#include <vector>

#include <glm/vec3.hpp>

#include "implicit/field.h"

namespace isoforge::implicit {

/// One box of a union: a centred box (half sizes, rounding) seen through translations.
struct BoxTerm {
    FieldPtr field;  ///< the box under its transforms as a field of its own (bounds and pruning)
    glm::vec3 half{0.f};
    float rounding = 0.f;
    std::vector<glm::vec3> shifts;  ///< local point = ((p + shifts[0]) + shifts[1]) + ..., outermost first
};

/// The most translations a box of a union may sit under. A chain of translations is applied once per
/// level in a tree but once per box in a union, so a box nested deeper (a recursive module's chain of
/// translate-and-union, thousands deep) stays in the tree instead of costing depth times boxes per point.
inline constexpr std::size_t kMaxBoxShifts = 8;

/// min over the boxes, with the same bits as the tree it replaces (a union of the terms' fields in
/// order): the same float operations per box, and the first of equals decides the gradient.
/// @pre at least two terms.
FieldPtr makeBoxUnion(std::vector<BoxTerm> terms);

/// The children as a union: runs of two or more consecutive children made only of boxes under
/// translations (Field::asBoxes) become one makeBoxUnion each, the others stay as they are, in
/// order. Used by unions (all children) and differences (all but the first).
std::vector<FieldPtr> groupBoxes(std::vector<FieldPtr> children);

}  // namespace isoforge::implicit
