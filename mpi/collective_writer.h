#pragma once
/// @file Writing the ranks' pieces (mpi/distributed_mesh.h) into one mesh file with MPI-IO: the same
/// bytes as the serial writer (mesh/io.h), whatever the rank count. Each rank formats its own records
/// (mesh/records.h); an exclusive scan of their lengths gives each its offset in every section of
/// the file (header, vertices, normals, faces), and all write at once. The file is written under a
/// temporary name beside the target and renamed by rank 0 once every rank has written, so that a
/// failed job leaves no partial output.

#include <string>

#include <mpi.h>

#include "mpi/distributed_mesh.h"

namespace isoforge::mpi {

struct CollectiveWriteOptions {
    bool ascii = false;   ///< PLY: ASCII instead of binary
    bool colors = false;  ///< the pieces carry colours (written only if some vertex is not white)
};

/// Writes `path` (.ply .obj .stl) from every rank's piece (collective over `comm`).
/// @throw IoError on this rank's failure; the caller makes the job agree before renaming.
/// @return the temporary file to rename onto `path` (rank 0 does, see commitCollective)
std::string writeCollective(const std::string& path, const RankPiece& piece, const CollectiveWriteOptions& options,
                            MPI_Comm comm);

/// Rank 0 renames the temporary file onto the target (after every rank reported success), or
/// removes it; collective.
void finishCollective(const std::string& temporary, const std::string& path, bool success, MPI_Comm comm);

/// True for the formats writeCollective writes (.ply .obj .stl).
bool canWriteCollective(const std::string& path);

}  // namespace isoforge::mpi
