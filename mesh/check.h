#pragma once
/// @file Topological and geometric validation of triangle meshes (the vocabulary of the seed, §3.3):
/// boundary and non-manifold edges, non-manifold vertices, orientation, degenerate triangles,
/// Euler characteristic, genus, components, area and enclosed volume.

#include <cstddef>
#include <optional>
#include <string>

#include "mesh/self_intersections.h"
#include "mesh/trimesh.h"

namespace isoforge::mesh {

struct MeshReport {
    std::size_t vertices = 0;      ///< positions in the mesh
    std::size_t usedVertices = 0;  ///< positions referenced by at least one triangle
    std::size_t triangles = 0;
    std::size_t edges = 0;                   ///< distinct undirected edges
    std::size_t boundaryEdges = 0;           ///< edges with exactly one triangle
    std::size_t nonManifoldEdges = 0;        ///< edges with three or more triangles
    std::size_t misorientedEdges = 0;        ///< manifold edges whose two triangles traverse them the same way
    std::size_t nonManifoldVertices = 0;     ///< vertices whose triangles form more than one fan
    std::size_t repeatedIndexTriangles = 0;  ///< a triangle naming one vertex twice
    std::size_t zeroAreaTriangles = 0;       ///< distinct vertices but (numerically) no area
    std::size_t duplicateTriangles = 0;      ///< same three vertices as an earlier triangle
    std::size_t outOfRangeIndices = 0;       ///< triangles naming a vertex that does not exist
    std::size_t components = 0;              ///< connected through shared vertices
    std::size_t negativeComponents = 0;  ///< closed components with negative enclosed volume (cavities, or inside-out)
    long long eulerCharacteristic = 0;   ///< V - E + F over used vertices
    double area = 0.0;
    double volume = 0.0;                    ///< signed; meaningful when watertight
    std::size_t weldedVertices = 0;         ///< with CheckOptions::weldByPosition: copies counted as one
    bool selfIntersectionsChecked = false;  ///< asked for (CheckOptions); then selfIntersections holds the count
    SelfIntersections selfIntersections;

    bool isWatertight() const { return boundaryEdges == 0 && nonManifoldEdges == 0 && outOfRangeIndices == 0; }
    bool isEdgeManifold() const { return nonManifoldEdges == 0; }
    bool isVertexManifold() const { return nonManifoldVertices == 0; }
    bool isOriented() const { return misorientedEdges == 0; }
    bool hasDegenerates() const {
        return repeatedIndexTriangles + zeroAreaTriangles + duplicateTriangles + outOfRangeIndices > 0;
    }
    /// Closed, 2-manifold, consistently oriented, no degenerate triangles, positive volume (and, when
    /// checked, no self-intersections).
    bool isValidClosedSurface() const {
        return isWatertight() && isVertexManifold() && isOriented() && !hasDegenerates() && volume > 0.0 &&
               triangles > 0 && (!selfIntersectionsChecked || selfIntersections.pairs == 0);
    }
    /// Sum of the genera of the components, for a closed oriented 2-manifold (V - E + F = 2C - 2g).
    std::optional<long long> genus() const;

    /// A multi-line human-readable report.
    std::string toString() const;
};

struct CheckOptions {
    bool selfIntersections = false;  ///< also count intersecting triangle pairs (mesh/self_intersections.h)
    /// Vertices with bit-identical positions count as one (a copy of the mesh welded first): a mesh whose
    /// vertices are split for per-side normals at creases (mesh/crease_normals.h) is closed by position.
    bool weldByPosition = false;
};

/// Checks `mesh`. O(T log T) time; never modifies the mesh; never throws on bad indices
/// (they are counted in outOfRangeIndices).
MeshReport check(const TriMesh& mesh, const CheckOptions& options = {});

}  // namespace isoforge::mesh
