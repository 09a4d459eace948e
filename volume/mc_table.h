#pragma once
/// @file The marching-cubes case table, generated (not typed in) from one consistent rule.
///
/// Corner c of a cell sits at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1). Edge e runs along axis
/// a = e / 4 from the corner whose other two coordinates are (j & 1, j >> 1), j = e % 4, in
/// increasing axis order. Bit c of a case index is set when corner c is inside.
///
/// How the table is made (mc_table.cpp), and why it gives closed 2-manifolds:
///  * On each cube face the intersected edges are paired into segments. A face with four
///    intersected edges (two diagonal inside corners) always separates the inside corners. The
///    decision depends only on the face's four corners, so the two cells sharing the face agree:
///    no cracks.
///  * Segments are directed with the inside region on their right seen from outside the cell, so
///    they chain into closed cycles and a face segment is traversed in opposite directions by the
///    two cells that share it: consistent orientation, triangles counter-clockwise seen from
///    outside.
///  * Each cycle is triangulated without a diagonal that joins two vertices lying on edges of a
///    common face: such a diagonal could be chosen by the neighbour cell too, making an edge with
///    four triangles. Every mesh edge is therefore a face segment (two cells, two triangles) or a
///    cell-private diagonal (two triangles of one polygon): edge-manifold; each vertex lies in one
///    polygon per cell around its grid edge, so its triangles form one fan: vertex-manifold.

#include <array>
#include <cstdint>

namespace isoforge::volume::mc {

inline constexpr int kMaxTriangles = 5;

struct CaseTable {
    std::array<std::uint8_t, 256> triangleCount{};
    std::array<std::array<std::uint8_t, 3 * kMaxTriangles>, 256> edges{};  ///< 3 edge ids per triangle
};

/// The table, built on first use (thread-safe).
const CaseTable& caseTable();

/// Offset of the start corner of edge e, and its axis.
struct EdgeInfo {
    std::uint8_t dx, dy, dz, axis;
};
constexpr EdgeInfo edgeInfo(int e) {
    const int a = e / 4, j = e % 4;
    const int u = j & 1, v = j >> 1;
    if (a == 0) return {0, static_cast<std::uint8_t>(u), static_cast<std::uint8_t>(v), 0};
    if (a == 1) return {static_cast<std::uint8_t>(u), 0, static_cast<std::uint8_t>(v), 1};
    return {static_cast<std::uint8_t>(u), static_cast<std::uint8_t>(v), 0, 2};
}

}  // namespace isoforge::volume::mc
