#pragma once
/// @file Internal to volume/: what OpenVDB's reader takes on trust in a .vdb file, checked before it reads.
/// OpenVDB allocates what a length field says before reading the bytes (a metadata string of 3.7 GB
/// from a four-byte field; `reserve(gridCount)`; the `__delayedload` mask's counts), so a damaged or
/// hostile file could make it allocate far more than the file holds. This walks the file's layout —
/// header, file metadata, grid count, each grid's descriptor, metadata and transform name — and refuses
/// any length beyond the end of the file, any count more entries than the bytes left could hold, and any
/// typed metadata whose byte count is not its type's size (OpenVDB would read on from the wrong place).
/// The trees (topology and voxel buffers) are OpenVDB's to read: their sizes follow from node sizes, and
/// a short read there throws (readVdb's stream has exceptions on). In a file without grid offsets, a grid's
/// descriptor starts where the tree before it ends, which only reading that tree finds: readVdb reads grid
/// by grid and checks each descriptor with checkGridHeader first.
#include <cstdint>
#include <filesystem>
#include <istream>

namespace isoforge::volume::detail {

struct VdbLayout {
    std::uint32_t version = 0;  ///< the file format version (OpenVDB's, e.g. 224)
    bool offsets = true;        ///< whether descriptors give each grid's place in the file
};

/// Checks the header, the file metadata and the grid count; the stream is left at its start.
/// @throw IoError naming the file, the byte offset and the field, on a layout OpenVDB should not read.
VdbLayout checkVdbLayout(std::istream& in, std::uint64_t fileSize, const std::filesystem::path& path);
/// Checks one grid's descriptor, metadata and transform name at byte `at`; the stream is left there.
void checkGridHeader(std::istream& in, std::uint64_t at, const VdbLayout& layout, std::uint64_t fileSize,
                     const std::filesystem::path& path);

}  // namespace isoforge::volume::detail
