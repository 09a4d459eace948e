#pragma once
/// @file The interface of the text module (csg/text_module.cpp), loaded with dlopen by csg/text.cpp.

#include <string>
#include <vector>

#include "csg/profile.h"
#include "csg/text.h"

namespace isoforge::csg {

inline constexpr int kTextModuleAbi = 1;

struct TextModule {
    int abi;
    /// Each glyph's outlines as FreeType gives them, placed and scaled as OpenSCAD places them.
    /// @throw std::runtime_error when no font is found.
    std::vector<Profile> (*glyphs)(const TextParams& p, std::string* fontUsed);
};

}  // namespace isoforge::csg
