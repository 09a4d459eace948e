#pragma once
/// @file A volume file's voxels read a run of slices at a time, without holding the volume: where its
/// header says they are (one file or several, raw or zlib/gzip-compressed, after a header), and a
/// stream that converts them to float in order. `isoforge mesh VOLUME --memory` and isoforge-mpi read
/// volumes larger than memory this way, keeping the blocks near the iso-value (volume/near_level.h).

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "volume/dense_volume.h"

namespace isoforge::volume {

/// Where a volume file's voxels are, from its header alone.
struct VoxelSource {
    /// What readVolume gives, but no values: dims, matrix, format, stored type, notes, files.
    DenseVolume header;
    struct Part {
        std::filesystem::path file;
        std::uint64_t offset = 0;  ///< where the part's bytes start in the file (compressed, if compressed)
        std::uint64_t skip = 0;    ///< decoded bytes to drop first (NRRD's byte skip on gzip data)
        std::uint64_t bytes = 0;   ///< voxel bytes the part holds, decoded
        bool compressed = false;   ///< a zlib or gzip stream
    };
    std::vector<Part> parts;  ///< consecutive pieces of the voxels: x fastest, then y, then z
    bool bigEndian = false;
    float slope = 1.f, intercept = 0.f;  ///< values are slope * stored + intercept (NIfTI's scl_slope, scl_inter)
    /// A DICOM series (its directory, and the series asked for): no parts; the slices come from the
    /// helper that reads them with GDCM, one file at a time, in the order of their positions.
    std::filesystem::path dicomDirectory;
    std::string dicomSeries;
};

/// The source of a volume file's voxels, reading only its header (a DICOM series: its files' headers
/// and its first slice, in the helper). nullopt for what is read whole only: a .vdb grid, NRRD's
/// bzip2, hex and text encodings.
/// @throw IoError for what readVolume refuses in a header (the same messages)
std::optional<VoxelSource> voxelSource(const std::filesystem::path& path, const VolumeReadOptions& options = {});

/// A source's voxels in order, whole slices at a time.
class SliceStream {
public:
    explicit SliceStream(const VoxelSource& source);
    ~SliceStream();
    SliceStream(const SliceStream&) = delete;
    SliceStream& operator=(const SliceStream&) = delete;

    /// The next `count` slices as floats: dims[0] * dims[1] * count values into `out`.
    /// @throw IoError when the data ends early or is corrupt, naming the file and how far it got
    void read(std::int64_t count, float* out);

private:
    struct State;
    std::unique_ptr<State> state_;
};

}  // namespace isoforge::volume
