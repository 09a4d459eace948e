#pragma once
/// @file `isoforge mesh --memory LIMIT`: a field meshed slab by slab (volume/bricked.h) into a file
/// written piece by piece (mesh/stream_writer.h); the same bytes as the in-memory path.

#include <cstdint>
#include <string>

#include "app/commands.h"
#include "implicit/field.h"
#include "volume/dense_volume.h"
#include "volume/marching_cubes.h"
#include "volume/sample.h"
#include "volume/voxel_source.h"

namespace isoforge::app {

/// One of: a field (sampled a slab at a time), a volume file streamed (never held
/// whole), a dense volume (converted a slab at a time; the volume itself is held: DICOM), a grid already
/// in memory (only the mesh is held a slab at a time).
struct SlabMeshJob {
    implicit::FieldPtr field;
    const volume::VoxelSource* source = nullptr;
    const volume::DenseVolume* volume = nullptr;
    openvdb::FloatGrid::ConstPtr grid;
    std::string what;              ///< for messages: the field, the file
    volume::SampleOptions sample;  ///< voxel size, band, clip (memoryLimit is set from memoryLimit)
    float isovalue = 0.f;
    volume::InsideSide inside = volume::InsideSide::Auto;
    bool normals = false, indexSpace = false, ascii = false, stats = false;
    std::string output;
    std::uint64_t memoryLimit = 0;  ///< bytes: the peak resident memory to stay under
    bool memoryGiven = true;        ///< --memory was given (else the limit is half the machine's, chosen for it)
};

/// Meshes the job into job.output, prints the summary unless quiet; returns the exit status.
/// @throw ResourceError when the limit is below what the process already holds, or a slab outgrows it.
int meshBySlabsToFile(const SlabMeshJob& job, const GlobalOptions& g);

}  // namespace isoforge::app
