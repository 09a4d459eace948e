#pragma once
/// @file Internal to volume/: the format readers behind readVolume, and helpers they share.

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/isolate.h"
#include "volume/dense_volume.h"
#include "volume/voxel_source.h"

namespace isoforge::volume::detail {

DenseVolume readNifti(const std::filesystem::path& path);
DenseVolume readNrrd(const std::filesystem::path& path);
DenseVolume readMetaImage(const std::filesystem::path& path);
DenseVolume readDicomSeries(const std::filesystem::path& dir, const std::string& series);
/// What readDicomSeries runs in its helper program (volume/dicom_reader_main.cpp): GDCM in this process.
DenseVolume readDicomSeriesHere(const std::filesystem::path& dir, const std::string& series);
/// What a streamed DICOM read runs in its helper (a HelperStream): the volume's description
/// (describeVolume, no voxels) once the first slice is read, then every slice's floats, one part each;
/// with `headerOnly`, the description alone. It holds one slice at a time.
void streamDicomSeriesHere(const std::filesystem::path& dir, const std::string& series, bool headerOnly,
                           const HelperSend& send);
/// The memory the DICOM helper may use for the files of `dir` (its address-space limit): for a whole
/// read, what all of them justify; for a streamed one, what the largest does.
std::uint64_t dicomMemoryLimit(const std::filesystem::path& dir, bool streamed = false);
/// A DICOM series as a voxel source: its header from the helper (which reads the first slice for it).
VoxelSource dicomSource(const std::filesystem::path& dir, const std::string& series);
/// A DICOM series' slices in order, from a helper that streams them (SliceStream's DICOM side).
class DicomSlices {
public:
    explicit DicomSlices(const VoxelSource& source);
    ~DicomSlices();
    /// The next `count` slices as floats into `out`. @throw IoError as the helper reports.
    void read(std::int64_t count, float* out);

private:
    const VoxelSource& source_;
    std::unique_ptr<HelperStream> helper_;
    std::int64_t delivered_ = 0;
};
/// A volume as the helper answers it: its voxels (floats), then describeVolume's bytes: the dimensions, the
/// matrix and the strings, ending with their own size (8 bytes).
std::string describeVolume(const DenseVolume& v);
/// The volume from the first `bytes` bytes of `buffer`, which hold such an answer (the buffer becomes its
/// voxels). @throw IoError for an answer that is short or of the wrong size.
DenseVolume volumeFromAnswer(std::vector<float> buffer, std::uint64_t bytes, const std::string& what);
/// The whole answer in one string and back (the fuzz target's round trip).
std::string serializeVolume(const DenseVolume& v);
DenseVolume deserializeVolume(const std::string& bytes, const std::string& what);
DenseVolume readRaw(const std::filesystem::path& path, const VolumeReadOptions& o);
DenseVolume readVdbVolume(const std::filesystem::path& path, const std::string& grid);

/// Where the voxels of each format are, from the header alone (volume/voxel_source.h).
VoxelSource niftiSource(const std::filesystem::path& path);
std::optional<VoxelSource> nrrdSource(const std::filesystem::path& path);  ///< nullopt: not raw or gzip
VoxelSource metaImageSource(const std::filesystem::path& path);
VoxelSource rawSource(const std::filesystem::path& path, const VolumeReadOptions& o);

/// lo = min(lo, v), hi = max(hi, v) over the values in order, NaNs never taken (unless the first value, the
/// start of lo and hi, is one): a volume read in runs of slices gets the range of the whole.
void extendRange(const float* values, std::size_t count, float& lo, float& hi);

/// Refuses dimensions outside 1 .. 2^20.
void checkVolumeDims(const std::filesystem::path& path, const std::array<std::int64_t, 3>& dims);

/// Refuses volumes whose float copy would not fit in half of this machine's memory, with the estimate.
void checkVolumeSize(const std::filesystem::path& path, const std::array<std::int64_t, 3>& dims);

/// Bytes per voxel of a type name ("uint8", "int16", ..., "float64"); 0 for an unknown name.
std::size_t typeSize(const std::string& type);

/// Converts `count` stored voxels of `type` (with the given byte order) to float, into `out`.
void convertVoxels(const void* data, const std::string& type, bool bigEndian, std::size_t count, float* out);

/// Inflates a zlib or gzip stream that must hold exactly `expected` bytes.
/// @throw IoError if it is cut short ("truncated") or corrupt, naming `path`.
std::vector<char> inflateExactly(const std::filesystem::path& path, const char* data, std::size_t size,
                                 std::size_t expected);

}  // namespace isoforge::volume::detail
