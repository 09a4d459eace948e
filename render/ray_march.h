#pragma once
/// @file Direct iso-surface ray marching, no mesh: on an implicit field (rays walk a grid of cells
/// that each hold the field simplified to them or are known empty or full, render/field_grid.h; in a
/// cell, sphere tracing where the field has a known gradient bound (distance fields, most tapes),
/// elsewhere subdivision of the ray by the field's
/// conservative interval bound, so thin parts are not stepped over) and on an OpenVDB float grid
/// (render/grid_march.h). Same camera, lights and shading as the Embree path.

#include "implicit/field.h"
#include "render/scene.h"

namespace isoforge::render {

/// Renders the zero set of `field` inside `region` (the field's bounds, or a clip box for
/// unbounded fields). Materials come from field->materialAt at the hit.
Frame marchField(const implicit::FieldPtr& field, const implicit::Box3& region, const Look& look,
                 const RenderOptions& options, RenderStats* stats = nullptr);

}  // namespace isoforge::render
