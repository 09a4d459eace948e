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

enum class LabelMethod {
    /// Shared boundaries (the default): the cells between voxel centres are cut into six tetrahedra each
    /// (Kuhn's triangulation, the same across neighbouring cells), and every tetrahedron edge whose two
    /// voxels differ in label gets the two triangles of its dual face in the barycentric subdivision
    /// (edge midpoint, the centroid of each tetrahedron face holding the edge, the tetrahedron's centroid).
    /// Each such triangle belongs to both labels with opposite orientations, so touching labels share their
    /// boundary exactly: no gaps, no overlaps, also where three or more labels meet; and each label's surface
    /// is a closed 2-manifold (every bichromatic pattern of a triangle or tetrahedron gives a disk).
    Shared,
    /// Our marching cubes on each label's indicator at 0.5, each label on its own: smoother, and closed and
    /// manifold per label, but where three labels meet or on ambiguous faces two labels' surfaces cross
    /// within a voxel instead of coinciding (83% of the AAL atlas's interface triangles are shared).
    MarchingCubes,
};

/// One surface per non-zero label (values are rounded to integers), closed and outward, in the volume's
/// world coordinates, in increasing label order. Deterministic (the same meshes whatever the thread count).
std::vector<LabelSurface> labelSurfaces(const DenseVolume& volume, Progress* progress = nullptr,
                                        LabelMethod method = LabelMethod::Shared);

}  // namespace isoforge::volume
