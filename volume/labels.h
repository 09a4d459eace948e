#pragma once
/// @file Label maps (segmentations, atlases): one closed surface per label, and colour tables.

#include <array>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "core/progress.h"
#include "mesh/trimesh.h"
#include "volume/dense_volume.h"

namespace isoforge::volume {

struct LabelInfo {
    std::string name;
    std::array<float, 3> color{0.7f, 0.7f, 0.7f};  ///< sRGB in [0, 1]
    bool hasColor = false;
};
using LabelTable = std::map<int, LabelInfo>;

/// Reads a colour or name table: a binary .lut of 768 bytes (256 reds, 256 greens, 256 blues, as
/// MRIcron and ImageJ write), or a text table with one label per line: ITK-SNAP ("idx r g b a vis msh
/// \"name\""), 3D Slicer ("idx name r g b a"), "idx name colour-name r g b" or a names-only list
/// ("idx name code", as the AAL atlas ships). Lines starting with '#' are comments.
/// @throw IoError with file:line on lines it cannot read.
LabelTable readLabelTable(const std::filesystem::path& path);

/// A distinct colour for a label without one (golden-ratio hues; deterministic).
std::array<float, 3> defaultLabelColor(int label);

struct LabelSurface {
    int label = 0;
    std::size_t voxels = 0;
    mesh::TriMesh mesh;  ///< closed, outward, in the volume's world coordinates
};

/// One surface per non-zero label (values are rounded to integers): the boundary of the label's voxels,
/// by our marching cubes on the label's indicator (1 inside, 0 outside) at 0.5, in the label's own
/// bounding box. Each surface is closed and outward; two labels that touch meet on the same plane
/// midway between their voxels. Labels are meshed in parallel and returned in increasing order.
std::vector<LabelSurface> labelSurfaces(const DenseVolume& volume, Progress* progress = nullptr);

}  // namespace isoforge::volume
