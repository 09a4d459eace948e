#pragma once
/// @file Mesh repair (the seed's §3.3 on orientation): drop degenerate and duplicate triangles, make
/// each component's orientation consistent (breadth first over shared edges), then outward: a
/// closed component nested inside an odd number of others is a cavity and faces inward, any other
/// faces outward (positive signed volume). What cannot be fixed is reported, not hidden.

#include <cstddef>
#include <string>

#include "mesh/trimesh.h"

namespace isoforge::mesh {

struct RepairReport {
    std::size_t degenerateRemoved = 0;   ///< repeated indices or zero area
    std::size_t duplicatesRemoved = 0;   ///< same three vertices as an earlier triangle
    std::size_t trianglesFlipped = 0;    ///< to agree with their component
    std::size_t componentsInverted = 0;  ///< whole components turned outward (or inward, for cavities)
    std::size_t nonOrientableComponents = 0;
    std::size_t nonManifoldEdges = 0;  ///< edges of more than two triangles: orientation does not cross them
    std::size_t openComponents = 0;    ///< with boundary edges: oriented consistently, not outward-tested
    std::string toString() const;
};

/// Repairs `mesh` in place (positions untouched, unused vertices kept).
RepairReport repair(TriMesh& mesh);

}  // namespace isoforge::mesh
