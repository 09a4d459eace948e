#pragma once
/// @file OpenSCAD's surface(): a height map read from a .dat file, as the closed polyhedron OpenSCAD
/// builds from it (surface.cc, 2021.01).

#include <string>
#include <vector>

#include "mesh/trimesh.h"

namespace isoforge::csg {

/// Heights by row (a row per line of the file; missing entries of shorter rows are 0, as in OpenSCAD).
struct HeightMap {
    std::vector<std::vector<double>> rows;
    std::size_t columns = 0;
};

/// OpenSCAD's .dat reader: lines of numbers separated by spaces or tabs; empty lines and lines that
/// start with '#' are skipped; reading stops at the first value that is not a number, with a
/// warning (added to `warnings`) naming the file and its line. @throw IoError when it cannot be read.
HeightMap readHeightMap(const std::string& path, std::vector<std::string>& warnings);

/// The solid under the height map: row i at y = i, column j at x = j (centred on the origin with
/// `center`), each cell four triangles to its mean height at its centre, walls down to a flat
/// bottom at min(0, lowest height - 1). Empty when the map has fewer than 2 rows or columns.
mesh::TriMesh surfaceMesh(const HeightMap& map, bool center);

}  // namespace isoforge::csg
