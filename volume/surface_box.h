#pragma once
/// @file The box of a field's surface as marching cubes finds it: what automatic framing fits. A
/// field's own bounds() are often loose (a blobby's are its balls' supports, a difference's or an
/// intersection's its first child's), while a mesh's vertices lie on the surface: the ray-marching
/// path frames this box so that it shows the view the mesh path shows.

#include "implicit/field.h"

namespace isoforge::volume {

/// The bounds of the vertices of the field's marching-cubes mesh at `resolution` voxels along the
/// longest side of its domain (sampleDomain(field, clip)); empty when it has none. Vertices lie on
/// the interpolated surface, so the box is within the chords' error of the surface's, whatever the
/// resolution, save parts thinner than a voxel.
implicit::Box3 surfaceBox(const implicit::FieldPtr& field, const implicit::Box3& clip, int resolution);

/// What automatic framing fits for a field rendered without a mesh (the command line's and Python's
/// render): surfaceBox() at 128 voxels where the domain is bounded and holds a surface, else the
/// domain, else [-1, 1]^3.
implicit::Box3 framingBox(const implicit::FieldPtr& field, const implicit::Box3& clip);

}  // namespace isoforge::volume
