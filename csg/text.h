#pragma once
/// @file OpenSCAD's text(): glyph outlines laid out as OpenSCAD 2021.01 lays them out (fontconfig to
/// find the font, HarfBuzz to shape, FreeType for the outlines, its Bezier flattening and offsets),
/// as a 2D profile.

#include <string>

#include "csg/profile.h"

namespace isoforge::csg {

struct TextParams {
    std::string text, font, direction, language = "en", script, halign = "left", valign = "baseline";
    double size = 10, spacing = 1;
    int segments = 2;  ///< points per Bezier curve: max(floor(fragments(size) / 8) + 1, 2), as OpenSCAD
};

/// The text's outlines, each glyph's united (Clipper, non-zero rule) as OpenSCAD unites them.
/// `fontUsed` gets the font file fontconfig chose. @throw std::runtime_error when no font is found.
Profile textProfile(const TextParams& p, std::string* fontUsed = nullptr);

}  // namespace isoforge::csg
