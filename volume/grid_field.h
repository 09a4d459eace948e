#pragma once
/// @file A float grid seen as an implicit field, so volumes take part in CSG scenes
/// (`volume("file.vdb", iso=...)`): trilinear values, negative inside, with bounds from per-leaf
/// value ranges so that sampling skips the regions of the grid that cannot hold the surface.

#include <filesystem>
#include <optional>
#include <string>

#include "implicit/field.h"

namespace isoforge::volume {

/// The field (value - iso) when the inside is below iso (level sets, or grids whose metadata says
/// so), else (iso - value), e.g. CT densities where bone is above the threshold.
/// @throw IoError from the reader; std::invalid_argument for a grid with no values.
implicit::FieldPtr makeGridField(const std::filesystem::path& path, float iso,
                                 const std::optional<std::string>& gridName = {});

}  // namespace isoforge::volume
