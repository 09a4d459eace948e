#pragma once
/// @file Feature vertices for marching cubes meshes (`isoforge mesh --sharp`): one vertex per cell
/// patch placed by a quadric error function on Hermite data, where it keeps every guarantee of
/// the marching cubes mesh (docs/marching-cubes.md, "Sharp features", gives the argument).

#include <cstddef>
#include <functional>
#include <span>
#include <type_traits>

#include <openvdb/openvdb.h>
#include <glm/vec3.hpp>

#include "mesh/trimesh.h"

namespace isoforge::volume {

struct SharpenStats {
    std::size_t patches = 0;          ///< single-patch cells looked at
    std::size_t features = 0;         ///< patches given a feature vertex (rank 2: edge, rank 3: corner)
    std::size_t reached = 0;          ///< of those, vertices beyond their cell, in empty cells (a tip, a thin edge)
    std::size_t flat = 0;             ///< left as they were: one normal direction, nothing to sharpen
    std::size_t kept = 0;             ///< left as they were: the feature vertex would leave the cell or fold the fan
    std::size_t sharedCells = 0;      ///< cells with two or more patches (left as they were)
    std::size_t refinedVertices = 0;  ///< edge crossings moved onto the field's own zero
    std::size_t flips = 0;            ///< edges flipped to follow a crease from feature vertex to feature vertex
};

/// The field in index space (voxel units) at a batch of points: `values(p, out)` sets `out[i]` to the
/// value at `p[i]`, negative inside, zero on the surface; `gradients(p, out)`, where given, the field's
/// own gradient there (per voxel: the active branch of a CSG tree's min and max, a polyhedron's face
/// normal), else sharpening takes central differences of the values 1e-3 voxels apart. Called from
/// several threads at once.
struct IndexValues {
    using Values = std::function<void(std::span<const glm::vec3> p, std::span<float> out)>;
    using Gradients = std::function<void(std::span<const glm::vec3> p, std::span<glm::vec3> out)>;
    Values values;
    Gradients gradients;

    IndexValues(Values v, Gradients g = {}) : values(std::move(v)), gradients(std::move(g)) {}
    template <class F>
    requires std::is_invocable_v<F&, std::span<const glm::vec3>, std::span<float>> IndexValues(F f)
        : values(std::move(f)) {}  // NOLINT: a function of values alone converts
    void operator()(std::span<const glm::vec3> p, std::span<float> out) const { values(p, out); }
};
/// The field for points within the index-space box [lo, hi]: the field's values (and gradients)
/// there (a CSG field pruned to the box, say: `implicit::Field::simplify`). Sharpening asks once per
/// batch of neighbouring vertices or cells and evaluates in batches.
using IndexField = std::function<IndexValues(const glm::vec3& lo, const glm::vec3& hi)>;

/// An IndexField from a function of one point (no pruning; tests and small fields).
IndexField pointwise(std::function<float(const glm::vec3&)> value);

/// Sharpens `mesh` in place. It must be marching cubes' output in index space (extractIsosurface
/// with worldSpace = false): vertices on grid edges, triangles within their cells, inside below.
/// Edge crossings are first moved onto the zero of `value` along their edge (regula falsi), then each
/// cell with one patch of rank 2 or 3 Hermite data gets the QEF's point (double precision, eigenvalues
/// under 1/10 of the largest dropped, centred on the crossings' mean) as a fan apex, if the point lies
/// inside the cell and the fan over the patch's boundary is a graph over the patch's plane (no fold).
/// Otherwise the cell keeps its marching cubes triangles. Deterministic; new vertices are appended.
/// `samples`, where given, is the grid the mesh was extracted from, sampled from the same field at
/// iso-value 0: the crossings' edge ends take its active values instead of evaluating the field again.
void sharpen(mesh::TriMesh& mesh, const IndexField& field, SharpenStats* stats = nullptr,
             const openvdb::FloatGrid* samples = nullptr);

/// The same for a grid's iso-surface: Hermite data from the grid's trilinear interpolant (its
/// crossings and gradient), the inside on the side `insideBelow` says.
void sharpenWithGrid(mesh::TriMesh& mesh, const openvdb::FloatGrid& grid, float iso, bool insideBelow,
                     SharpenStats* stats = nullptr);

}  // namespace isoforge::volume
