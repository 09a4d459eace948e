#pragma once
/// @file Dense scalar volumes read from medical and raw files: NIfTI-1/2 (niftilib), NRRD (teem),
/// MetaImage (.mha/.mhd, read here: a text header and raw or zlib data), DICOM series (GDCM), raw
/// voxels, and .vdb. Every reader turns spacing, origin and orientation into one index-to-world
/// matrix in patient LPS millimetres (x towards the patient's left, y towards the back, z towards the
/// head: DICOM's and ITK's convention; NIfTI's RAS is converted by negating x and y), so meshes come
/// out in patient coordinates and left stays left. Heavy library headers stay in the .cpp files.

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

namespace isoforge::volume {

/// A dense 3D scalar volume, values as float, x (column) fastest, then y (row), then z (slice).
struct DenseVolume {
    std::array<std::int64_t, 3> dims{0, 0, 0};
    std::vector<float> values;
    glm::dmat4 indexToWorld{1.0};  ///< voxel centre (i, j, k) -> patient LPS millimetres

    std::string format;              ///< "NIfTI-1", "NIfTI-2", "NRRD", "MetaImage", "DICOM", "raw", "VDB"
    std::string storedType;          ///< the file's voxel type: "uint8", "int16", "float32", ...
    std::string units;               ///< "HU" for CT with rescale, else empty
    std::string modality;            ///< DICOM modality ("CT", "MR"), else empty
    std::size_t files = 1;           ///< files read (DICOM slices, multi-file NRRD)
    std::vector<std::string> notes;  ///< further facts for `isoforge info` (series UID, space, ...)

    std::size_t voxelCount() const { return std::size_t(dims[0]) * std::size_t(dims[1]) * std::size_t(dims[2]); }
    float at(std::int64_t i, std::int64_t j, std::int64_t k) const {
        return values[std::size_t((k * dims[1] + j) * dims[0] + i)];
    }
    /// Voxel spacing along each index axis (lengths of the matrix's columns), millimetres.
    glm::dvec3 spacing() const;
    /// Unit direction of each index axis in LPS.
    glm::dmat3 directions() const;
    /// The anatomical direction each index axis points to most, as three letters (towards which the index
    /// increases): "LPS" for DICOM's usual axial slices, "RAS" for a typical NIfTI, "LAS", ...
    std::string orientationCode() const;
    /// Minimum and maximum value.
    std::pair<float, float> range() const;
};

/// How to read raw voxels, and which DICOM series to take from a directory that holds several.
struct VolumeReadOptions {
    std::array<std::int64_t, 3> rawDims{0, 0, 0};
    std::string rawType;  ///< uint8 int8 uint16 int16 uint32 int32 float32 float64
    glm::dvec3 rawSpacing{1.0};
    bool rawBigEndian = false;
    std::uint64_t rawOffset = 0;  ///< bytes to skip (a header)
    std::string dicomSeries;      ///< SeriesInstanceUID (or a unique prefix of it)
    std::string vdbGrid;          ///< grid name in a .vdb (default: the first float grid)
};

/// True if `path` names something readVolume reads: a directory (DICOM), .nii, .nii.gz, .nrrd, .nhdr,
/// .mha, .mhd, .raw, .vdb, .dcm.
bool isVolumePath(const std::filesystem::path& path);

/// Reads a volume; the format comes from the name (a directory is a DICOM series; .raw needs the raw
/// options). @throw IoError naming the file and the offending position or field and what was expected
/// (truncated data, a gzip stream cut short, a header promising more voxels than the file holds, a
/// DICOM slice of another series); ResourceError for volumes too large for this machine.
DenseVolume readVolume(const std::filesystem::path& path, const VolumeReadOptions& options = {});

/// Writes a NIfTI-1 file (.nii or .nii.gz; float32 voxels, the matrix as sform and qform in RAS),
/// atomically.
void writeNifti(const std::filesystem::path& path, const DenseVolume& volume);

}  // namespace isoforge::volume
