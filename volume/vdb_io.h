#pragma once
/// @file OpenVDB files: reading with clear errors, atomic writing, and grid descriptions.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <openvdb/openvdb.h>

namespace isoforge::volume {

/// Calls openvdb::initialize() once (thread-safe). The readers call it themselves.
void initializeOpenVdb();

/// Reads every grid of a .vdb file (fully, not delay-loaded).
/// @throw IoError naming the file and the problem (missing, not a VDB file, truncated, corrupt).
openvdb::GridPtrVec readVdb(const std::filesystem::path& path);

/// Reads one float grid: the one called `name`, or else the first float grid (a level set if any).
/// @throw IoError if there is no such grid, listing the grids the file holds and their types.
openvdb::FloatGrid::Ptr readFloatGrid(const std::filesystem::path& path, const std::optional<std::string>& name = {});

/// The grid readFloatGrid picks among grids read from `path` (named in its errors).
openvdb::FloatGrid::Ptr pickFloatGrid(const openvdb::GridPtrVec& grids, const std::filesystem::path& path,
                                      const std::optional<std::string>& name = {});

/// Writes grids atomically (temporary file, then rename).
/// @throw IoError on failure; no partial file is left.
void writeVdb(const std::filesystem::path& path, const openvdb::GridCPtrVec& grids);

/// Facts about a grid for `isoforge info`.
struct GridSummary {
    std::string name, type, gridClass;
    openvdb::Vec3d voxelSize;
    std::uint64_t activeVoxels = 0, leafNodes = 0, activeTiles = 0;
    openvdb::CoordBBox indexBounds;                        ///< bounding box of active values, index space
    openvdb::BBoxd worldBounds;                            ///< the same box in world space
    std::optional<double> background, minValue, maxValue;  ///< scalar grids only
    std::uint64_t memoryBytes = 0;
    bool uniformScale = true;
};
GridSummary summarize(const openvdb::GridBase& grid);
std::string toString(const GridSummary& s);

}  // namespace isoforge::volume
