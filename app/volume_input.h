#pragma once
/// @file Volume files on the command line: the raw-voxel and DICOM options, loading with a summary,
/// and the description `isoforge info` prints.

#include <string>
#include <vector>

#include <openvdb/openvdb.h>
#include <CLI/CLI.hpp>

#include "app/commands.h"
#include "core/progress.h"
#include "volume/dense_volume.h"

namespace isoforge::app {

struct VolumeInput {
    std::vector<std::int64_t> dims;
    std::vector<double> spacing;
    std::string type, endian = "little", series;
    std::uint64_t offset = 0;
    float tolerance = 0.f;
};

/// --dims, --type, --spacing, --endian, --offset (raw voxels), --series (DICOM).
void addVolumeReadOptions(CLI::App* cmd, VolumeInput& in);

/// True for volume files other than .vdb (medical formats, raw, a DICOM directory).
bool isDenseVolumeFile(const std::string& path);

/// The reader's options from the command line's.
volume::VolumeReadOptions readOptions(const VolumeInput& in);

/// Reads the volume; prints a line (format, dims, spacing, orientation, range, time) unless quiet.
volume::DenseVolume loadVolume(const std::string& path, const VolumeInput& in, const GlobalOptions& g);

/// A sparse grid of the volume (background: its minimum, culled within --tolerance), Gaussian-smoothed
/// `smooth` times (OpenVDB's filter, width 1) when asked.
openvdb::FloatGrid::Ptr volumeGrid(const volume::DenseVolume& v, const VolumeInput& in, int smooth, Progress* progress);

/// The grid of the volume's blocks near `level` alone (volume::toGridNearLevel, with toGrid's exterior):
/// for meshing at that level only, it gives volumeGrid's mesh from a fraction of the work and memory.
openvdb::FloatGrid::Ptr volumeGridNearLevel(const volume::DenseVolume& v, float level, bool insideAbove);

/// What `isoforge info` prints about a dense volume.
std::string describeVolume(const std::string& path, const volume::DenseVolume& v);

/// The summary's "read" line up to the range, as every path that reads a volume says it: "read PATH (FORMAT,
/// N files): X x Y x Z TYPE voxels, spacing ... mm, LPS, values LO .. HI[ UNITS]" (no newline).
std::string readSummary(const std::string& path, const volume::DenseVolume& v, std::pair<float, float> range);

}  // namespace isoforge::app
