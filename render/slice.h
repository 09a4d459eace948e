#pragma once
/// @file Planar slices of fields as images: the sign (black inside, white outside) or the values
/// through a diverging colour map with iso-lines.

#include <cstdint>

#include "implicit/field.h"
#include "render/image.h"

namespace isoforge::render {

struct SliceOptions {
    int axis = 2;               ///< the plane's normal: 0 x, 1 y, 2 z
    float offset = 0.f;         ///< the plane is axis = offset
    float lo = -1.f, hi = 1.f;  ///< the square range of the two in-plane axes
    int size = 1024;            ///< pixels per side
    bool sign = false;          ///< black inside, white outside; else colour-mapped values
};

struct SliceStats {
    std::uint64_t pointsEvaluated = 0, tilesFilled = 0, boundsEvaluated = 0;
    double seconds = 0;
};

/// Renders the slice. In-plane axes: z-plane x right, y up; x-plane y right, z up; y-plane x right,
/// z up. Row 0 is at the top (the range's maximum). Work is organised as a quadtree: a tile whose
/// bound proves its sign is filled at once (sign mode), others are split with the field simplified
/// to the tile (tape pruning), down to 8x8 tiles evaluated in one batch.
Image sliceField(const implicit::FieldPtr& field, const SliceOptions& options, SliceStats* stats = nullptr);

}  // namespace isoforge::render
