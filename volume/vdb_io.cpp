#include "volume/vdb_io.h"

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <mutex>
#include <sstream>

#include <openvdb/io/Archive.h>
#include <openvdb/io/File.h>
#include <openvdb/io/GridDescriptor.h>
#include <openvdb/io/Stream.h>
#include <openvdb/io/io.h>
#include <openvdb/tools/Count.h>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/file_read_buffer.h"
#include "volume/vdb_compression_guard.h"
#include "volume/vdb_layout.h"

namespace isoforge::volume {

void initializeOpenVdb() {
    static std::once_flag once;
    std::call_once(once, [] {
        openvdb::initialize();
        (void)detail::openVdbChunkReadersGuarded();  // links volume/vdb_compression_guard.cpp in
    });
}

namespace {

// Checks what OpenVDB's reader takes on trust, so that a damaged file gives an error rather than a
// crash or a huge allocation: the magic number, and that the file is not shorter than its header.
void precheck(const std::filesystem::path& path) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw IoError(path.string() + ": no such file");
    if (std::filesystem::is_directory(path, ec))
        throw IoError(path.string() + ": is a directory, expected a .vdb file");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError(path.string() + ": cannot open");
    unsigned char magic[8] = {};
    in.read(reinterpret_cast<char*>(magic), 8);
    if (in.gcount() < 8)
        throw IoError(path.string() + ": byte 0: file too short to be a VDB file (" + std::to_string(in.gcount()) +
                      " bytes)");
    // OpenVDB files start with the 64-bit magic number 0x56444220 ("VDB ") in little-endian order.
    if (!(magic[0] == 0x20 && magic[1] == 0x42 && magic[2] == 0x44 && magic[3] == 0x56))
        throw IoError(path.string() + ": byte 0: not an OpenVDB file (expected the magic number 'VDB ')");
}

}  // namespace

namespace {

// A file can place a tree's nodes anywhere in 32-bit coordinates, and a bounding box there (max - min + 1,
// in OpenVDB's Coord and in our dense extents) overflows. Real grids are nowhere near: 2^29 voxels of
// 0.1 mm is 54 km. Checked on the root's entries (children and tiles), which hold every other node.
constexpr std::int64_t kMaxCoordinate = std::int64_t(1) << 29;

/// The grid types isoforge reads: OpenVDB's registered ones less its point grids (PointIndexGrid, PointDataGrid).
using VolumeGridTypes =
    openvdb::NumericGridTypes::Append<openvdb::Vec3GridTypes>::Append<openvdb::BoolGrid, openvdb::MaskGrid>;

void checkCoordinates(const openvdb::GridBase& grid, const std::filesystem::path& path) {
    const auto rootEntries = [&](const auto& g) {
        for (auto it = g.tree().root().cbeginChildAll(); it; ++it) {
            const openvdb::Coord c = it.getCoord();
            for (int i = 0; i < 3; ++i)
                if (std::abs(std::int64_t(c[i])) > kMaxCoordinate)
                    throw IoError(path.string() + ": corrupt VDB file: grid '" + grid.getName() + "' has a node at (" +
                                  std::to_string(c.x()) + ", " + std::to_string(c.y()) + ", " + std::to_string(c.z()) +
                                  "), more than 2^29 voxels from the origin");
        }
    };
    grid.apply<VolumeGridTypes>(rootEntries);
}

// A linear transform must be invertible as OpenVDB inverts it: AffineMap refuses a determinant within
// 3e-15 of zero by throwing ArithmeticError from wherever the map is next turned affine (fuzz_vdb: a scale
// of zero read from the file reached toDense as an "internal error").
void checkTransform(const openvdb::GridBase& grid, const std::filesystem::path& path) {
    const openvdb::math::MapBase::ConstPtr map = grid.transform().baseMap();
    if (!map->isLinear()) return;  // frustum maps: refused where a linear one is needed
    const double det = map->determinant();
    if (!std::isfinite(det) || std::abs(det) <= 3.0 * openvdb::math::Tolerance<double>::value()) {
        std::ostringstream what;
        what << path.string() << ": corrupt VDB file: grid '" << grid.getName()
             << "' has a transform that cannot be inverted (" << map->type() << ", determinant " << det << ")";
        throw IoError(what.str());
    }
}

/// io::Stream's reading (without delayed loading), grid by grid through Archive's protected steps, so that
/// each grid's header is checked where the stream stands before OpenVDB reads it: in a file without grid
/// offsets, a grid name of 2 GB after the first grid's tree was a 2 GB string (fuzz_vdb).
class CheckedStream : public openvdb::io::Archive {
public:
    openvdb::GridPtrVec read(std::istream& is, const detail::VdbLayout& layout, std::uint64_t fileSize,
                             const std::filesystem::path& path) {
        readHeader(is);
        auto streamMetadata = std::make_shared<openvdb::io::StreamMetadata>();
        openvdb::io::setStreamMetadataPtr(is, streamMetadata, /*transfer=*/false);
        openvdb::io::setVersion(is, libraryVersion(), fileVersion());
        openvdb::io::setDataCompression(is, compression());
        openvdb::MetaMap fileMetadata;
        fileMetadata.readMeta(is);
        const std::int32_t count = readGridCount(is);
        openvdb::GridPtrVec grids;
        std::vector<openvdb::io::GridDescriptor> descriptors;
        NamedGridMap named;
        for (std::int32_t i = 0; i < count; ++i) {
            detail::checkGridHeader(is, std::uint64_t(is.tellg()), layout, fileSize, path);
            openvdb::io::GridDescriptor gd;
            gd.read(is);
            if (!openvdb::GridBase::isRegistered(gd.gridType()))
                throw IoError(path.string() + ": grid '" + gd.uniqueName() + "' is of an unknown type, '" +
                              gd.gridType() + "'");
            openvdb::GridBase::Ptr grid = openvdb::GridBase::createGrid(gd.gridType());
            // Volumes only: scalar, vector and mask grids. Point data grids hold attribute arrays that OpenVDB
            // decompresses with blosc from buffers it does not check (as it did the delayed-load metadata).
            const auto volume = [](const auto&) {};
            if (!grid->apply<VolumeGridTypes>(volume))
                throw IoError(path.string() + ": grid '" + gd.uniqueName() + "' is of type '" + gd.gridType() +
                              "', not a volume (isoforge reads scalar, vector and mask grids)");
            grid->setSaveFloatAsHalf(gd.saveFloatAsHalf());
            Archive::readGrid(grid, gd, is);
            grids.push_back(grid);
            descriptors.push_back(gd);
            named[gd.uniqueName()] = grid;
        }
        for (const openvdb::io::GridDescriptor& gd : descriptors) connectInstance(gd, named);  // shared trees
        return grids;
    }
};

openvdb::GridPtrVec readGrids(const std::filesystem::path& path) {
    // Read through a stream over the whole file: no delayed loading, no memory mapping, so a truncated
    // file fails here, in the reader, and not later while meshing. Its buffer keeps the position itself:
    // OpenVDB asks for it on every leaf (core/file_read_buffer.h).
    FileReadBuffer buffer(path);
    if (!buffer.isOpen()) throw IoError(path.string() + ": cannot open: " + std::strerror(errno));
    try {
        std::istream in(&buffer);
        const std::uint64_t fileSize = std::filesystem::file_size(path);
        const detail::VdbLayout layout = detail::checkVdbLayout(in, fileSize, path);
        // OpenVDB does not check its stream; make a short read throw at once, rather than letting
        // it parse zeros (which, besides giving garbage, leaks nodes inside OpenVDB).
        in.exceptions(std::ios::failbit | std::ios::badbit);
        const openvdb::GridPtrVec grids = CheckedStream().read(in, layout, fileSize, path);
        for (const auto& g : grids) {
            checkCoordinates(*g, path);
            checkTransform(*g, path);
        }
        return grids;
    } catch (const IoError&) {
        throw;
    } catch (const std::ios_base::failure&) {
        if (buffer.readError()) throw IoError(path.string() + ": cannot read: " + std::strerror(buffer.readError()));
        throw IoError(path.string() + ": truncated VDB file (data ends before the grids do)");
    } catch (const openvdb::Exception& e) {
        throw IoError(path.string() + ": corrupt or truncated VDB file: " + e.what());
    } catch (const std::bad_alloc&) {
        throw IoError(path.string() + ": corrupt VDB file (it asks for an impossible amount of memory)");
    } catch (const std::exception& e) {
        throw IoError(path.string() + ": corrupt or truncated VDB file: " + e.what());
    }
}

}  // namespace

openvdb::GridPtrVec readVdb(const std::filesystem::path& path) {
    initializeOpenVdb();
    precheck(path);
    return readGrids(path);
}

openvdb::FloatGrid::Ptr readFloatGrid(const std::filesystem::path& path, const std::optional<std::string>& name) {
    return pickFloatGrid(readVdb(path), path, name);
}

openvdb::FloatGrid::Ptr pickFloatGrid(const openvdb::GridPtrVec& grids, const std::filesystem::path& path,
                                      const std::optional<std::string>& name) {
    openvdb::FloatGrid::Ptr pick;
    for (const auto& g : grids) {
        auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
        if (name) {
            if (g->getName() == *name) {
                if (!f)
                    throw IoError(path.string() + ": grid '" + *name + "' is of type " + g->valueType() +
                                  "; isoforge meshes float grids");
                return f;
            }
            continue;
        }
        if (f && (!pick ||
                  (pick->getGridClass() != openvdb::GRID_LEVEL_SET && f->getGridClass() == openvdb::GRID_LEVEL_SET)))
            pick = f;
    }
    if (pick) return pick;
    std::string list;
    for (const auto& g : grids) list += "\n  '" + g->getName() + "' (" + g->valueType() + ")";
    if (grids.empty()) list = " none";
    throw IoError(path.string() + ": " + (name ? "no grid named '" + *name + "'" : std::string("no float grid")) +
                  "; the file holds:" + list);
}

void writeVdb(const std::filesystem::path& path, const openvdb::GridCPtrVec& grids) {
    initializeOpenVdb();
    AtomicFile out(path);
    try {
        std::ostringstream buffer(std::ios::binary);
        openvdb::io::Stream(buffer).write(grids);
        out.write(buffer.str());
    } catch (const openvdb::Exception& e) {
        throw IoError(path.string() + ": cannot write VDB: " + e.what());
    }
    out.commit();
}

GridSummary summarize(const openvdb::GridBase& grid) {
    GridSummary s;
    s.name = grid.getName();
    s.type = grid.valueType();
    s.gridClass = openvdb::GridBase::gridClassToString(grid.getGridClass());
    s.voxelSize = grid.voxelSize();
    s.uniformScale = grid.hasUniformVoxels();
    s.activeVoxels = grid.activeVoxelCount();
    s.indexBounds = grid.evalActiveVoxelBoundingBox();
    s.memoryBytes = grid.memUsage();
    if (!s.indexBounds.empty()) {
        openvdb::BBoxd box(s.indexBounds.min().asVec3d() - 0.5, s.indexBounds.max().asVec3d() + 0.5);
        s.worldBounds = grid.transform().indexToWorld(box);
    }
    if (const auto* f = dynamic_cast<const openvdb::FloatGrid*>(&grid)) {
        s.leafNodes = f->tree().leafCount();
        s.activeTiles = f->tree().activeTileCount();
        s.background = f->background();
        if (s.activeVoxels > 0) {
            openvdb::math::MinMax<float> mm = openvdb::tools::minMax(f->tree());
            s.minValue = mm.min();
            s.maxValue = mm.max();
        }
    } else if (const auto* d = dynamic_cast<const openvdb::DoubleGrid*>(&grid)) {
        s.leafNodes = d->tree().leafCount();
        s.activeTiles = d->tree().activeTileCount();
        s.background = d->background();
    }
    return s;
}

std::string toString(const GridSummary& s) {
    std::ostringstream o;
    o.precision(6);
    o << "grid '" << s.name << "'  " << s.type << ", " << s.gridClass << "\n";
    o << "  voxel size     " << s.voxelSize.x();
    if (!s.uniformScale) o << " x " << s.voxelSize.y() << " x " << s.voxelSize.z();
    o << "\n  active voxels  " << s.activeVoxels;
    if (s.activeTiles) o << " (" << s.activeTiles << " active tiles)";
    o << "\n  leaf nodes     " << s.leafNodes;
    if (s.indexBounds.empty()) {
        o << "\n  bounding box   empty";
    } else {
        const auto& a = s.indexBounds;
        o << "\n  index bbox     [" << a.min().x() << ", " << a.min().y() << ", " << a.min().z() << "] .. ["
          << a.max().x() << ", " << a.max().y() << ", " << a.max().z() << "]  (" << a.dim().x() << " x " << a.dim().y()
          << " x " << a.dim().z() << ")";
        const auto& w = s.worldBounds;
        o << "\n  world bbox     [" << w.min().x() << ", " << w.min().y() << ", " << w.min().z() << "] .. ["
          << w.max().x() << ", " << w.max().y() << ", " << w.max().z() << "]";
    }
    if (s.background) o << "\n  background     " << *s.background;
    if (s.minValue) o << "\n  value range    " << *s.minValue << " .. " << *s.maxValue << " (active)";
    o << "\n  memory         " << (s.memoryBytes + 512 * 1024) / (1024 * 1024) << " MiB\n";
    return o.str();
}

}  // namespace isoforge::volume
