#pragma once
/// @file One piece per rank and a ParaView index: `-o scene.pvtp` writes scene_0.vtp, scene_1.vtp, ...
/// (VTK XML PolyData, raw binary appended data: points, normals, connectivity, offsets) and the .pvtp
/// naming them. Each piece holds the rank's vertices and the ghosts its triangles use (the next rank's
/// first vertices), numbered from 0 within the piece; ParaView shows the pieces as one surface, and VTK's
/// vtkCleanPolyData merges the seams' duplicated points back to the whole mesh's vertices.

#include <string>

#include <mpi.h>

#include "mpi/distributed_mesh.h"

namespace isoforge::mpi {

/// Writes this rank's piece, and rank 0 the index (collective; every rank throws if any failed).
void writePieces(const std::string& pvtpPath, const RankPiece& piece, bool normals, MPI_Comm comm);

}  // namespace isoforge::mpi
