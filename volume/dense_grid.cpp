#include "volume/dense_grid.h"

#include <algorithm>
#include <limits>
#include <stdexcept>

#include <openvdb/tools/Dense.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "core/big_buffer.h"
#include "core/error.h"
#include "volume/readers.h"
#include "volume/vdb_io.h"

namespace isoforge::volume {

openvdb::math::Transform::Ptr transformOf(const glm::dmat4& m) {
    openvdb::Mat4d vdb;  // row-vector convention: row i is glm's column i
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) vdb[i][j] = m[i][j];
    return openvdb::math::Transform::createLinearTransform(vdb);
}

openvdb::FloatGrid::Ptr toGrid(const DenseVolume& v, const ToGridOptions& o) {
    ToGridOptions opt = o;
    if (!opt.background) opt.background = v.range().first;
    openvdb::FloatGrid::Ptr grid = toGrid(VolumeView{v.values.data(), v.dims, v.indexToWorld, v.format}, opt);
    if (!v.units.empty()) grid->insertMeta("units", openvdb::StringMetadata(v.units));
    if (!v.modality.empty()) grid->insertMeta("modality", openvdb::StringMetadata(v.modality));
    return grid;
}

openvdb::FloatGrid::Ptr toGrid(const VolumeView& v, const ToGridOptions& o) {
    initializeOpenVdb();
    const std::size_t count = std::size_t(v.dims[0]) * std::size_t(v.dims[1]) * std::size_t(v.dims[2]);
    const float background =
        o.background ? *o.background : (count ? *std::min_element(v.values, v.values + count) : 0.f);
    auto grid = openvdb::FloatGrid::create(background);
    grid->setTransform(transformOf(v.indexToWorld));
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    grid->insertMeta("isoforge_inside", openvdb::StringMetadata("above"));
    grid->insertMeta("source_format", openvdb::StringMetadata(v.format));
    const std::int64_t slab = 64, nz = v.dims[2];
    const std::int64_t xo = v.xOffset, x0 = std::clamp<std::int64_t>(o.xBegin, xo, xo + v.dims[0]),
                       x1 = std::clamp<std::int64_t>(o.xEnd, xo, xo + v.dims[0]);
    if (count == 0 || x1 <= x0) return grid;
    const bool whole = x0 == xo && x1 == xo + v.dims[0];
    std::vector<float> part;  // an x range is not contiguous: copied a run of slices at a time
    if (o.progress) o.progress->begin("converting to a sparse grid");
    for (std::int64_t z0 = 0; z0 < nz; z0 += slab) {
        const std::int64_t z1 = std::min(nz, z0 + slab) - 1;
        const openvdb::CoordBBox box(openvdb::Coord(int(x0), 0, int(z0)),
                                     openvdb::Coord(int(x1 - 1), int(v.dims[1] - 1), int(z1)));
        const float* data = v.values + std::size_t(z0 * v.dims[0] * v.dims[1]);
        if (!whole) {
            part.resize(std::size_t((x1 - x0) * v.dims[1] * (z1 - z0 + 1)));
            float* out = part.data();
            for (std::int64_t k = z0; k <= z1; ++k)
                for (std::int64_t j = 0; j < v.dims[1]; ++j, out += x1 - x0) {
                    const float* row = v.values + std::size_t((k * v.dims[1] + j) * v.dims[0] + x0 - xo);
                    std::copy(row, row + (x1 - x0), out);
                }
            data = part.data();
        }
        // A view of the slab in place (x fastest: OpenVDB's LayoutXYZ).
        openvdb::tools::Dense<const float, openvdb::tools::LayoutXYZ> dense(box, data);
        openvdb::tools::copyFromDense(dense, *grid, o.tolerance);
        if (o.progress) o.progress->update(std::size_t(z1 + 1), std::size_t(nz));
    }
    if (o.progress) o.progress->end();
    grid->pruneGrid(o.tolerance);
    return grid;
}

openvdb::FloatGrid::Ptr toGridNearLevel(const VolumeView& v, float level, bool insideAbove,
                                        std::pair<float, float>* range) {
    initializeOpenVdb();
    if (v.xOffset != 0) throw std::invalid_argument("toGridNearLevel takes a whole volume (xOffset 0)");
    const std::int64_t nx = v.dims[0], ny = v.dims[1], nz = v.dims[2];
    if (nx <= 0 || ny <= 0 || nz <= 0) {
        if (range) *range = {0.f, 0.f};
        return openvdb::FloatGrid::create(0.f);
    }
    const std::int64_t bx = (nx + 7) / 8, by = (ny + 7) / 8, bz = (nz + 7) / 8;
    const auto at = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
        return v.values[std::size_t((k * ny + j) * nx + i)];
    };
    // The range of each block and of the two voxels around it: rows' ranges over each block's x extent
    // widened by two voxels each way, then over each block's rows widened likewise in y and z.
    const float inf = std::numeric_limits<float>::infinity();
    // Per layer of blocks (parallel), in a buffer each thread reuses: the rows' ranges for the layer's
    // slices and two more each side, then each block's range over its rows.
    // kind: 0 outside, 1 inside (a tile), 2 both (a leaf). A block reaching past the array sees outside there.
    std::vector<std::uint8_t> kind(std::size_t(bx * by * bz));
    std::vector<float> layerLo(std::size_t(bz), inf), layerHi(std::size_t(bz), -inf);
    tbb::enumerable_thread_specific<std::vector<float>> scratch;
    tbb::parallel_for(std::int64_t{0}, bz, [&](std::int64_t K) {
        const std::int64_t k0 = std::max<std::int64_t>(8 * K - 2, 0), k1 = std::min(8 * K + 10, nz);
        std::vector<float>& buffer = scratch.local();
        const std::size_t rows = std::size_t((k1 - k0) * ny * bx);
        buffer.resize(2 * rows);
        float *rowLo = buffer.data(), *rowHi = buffer.data() + rows;
        float layerMin = inf, layerMax = -inf;
        for (std::int64_t k = k0; k < k1; ++k)
            for (std::int64_t j = 0; j < ny; ++j) {
                const float* p = v.values + std::size_t((k * ny + j) * nx);
                for (std::int64_t I = 0; I < bx; ++I) {
                    float lo = inf, hi = -inf;
                    for (std::int64_t i = std::max<std::int64_t>(8 * I - 2, 0); i < std::min(8 * I + 10, nx); ++i) {
                        lo = std::min(lo, p[i]);  // branch-free: vectorized
                        hi = std::max(hi, p[i]);
                    }
                    rowLo[std::size_t(((k - k0) * ny + j) * bx + I)] = lo;
                    rowHi[std::size_t(((k - k0) * ny + j) * bx + I)] = hi;
                    layerMin = std::min(layerMin, lo);
                    layerMax = std::max(layerMax, hi);
                }
            }
        layerLo[std::size_t(K)] = layerMin;
        layerHi[std::size_t(K)] = layerMax;
        for (std::int64_t J = 0; J < by; ++J)
            for (std::int64_t I = 0; I < bx; ++I) {
                float lo = inf, hi = -inf;
                for (std::int64_t k = k0; k < k1; ++k)
                    for (std::int64_t j = std::max<std::int64_t>(8 * J - 2, 0); j < std::min(8 * J + 10, ny); ++j) {
                        lo = std::min(lo, rowLo[std::size_t(((k - k0) * ny + j) * bx + I)]);
                        hi = std::max(hi, rowHi[std::size_t(((k - k0) * ny + j) * bx + I)]);
                    }
                const bool past = 8 * I - 2 < 0 || 8 * J - 2 < 0 || 8 * K - 2 < 0 || 8 * I + 10 > nx ||
                                  8 * J + 10 > ny || 8 * K + 10 > nz;
                const bool in = insideAbove ? hi > level : lo < level;
                const bool out = past || (insideAbove ? lo <= level : hi >= level);
                kind[std::size_t((K * by + J) * bx + I)] = in && out ? 2 : (in ? 1 : 0);
            }
    });
    const float minimum = *std::min_element(layerLo.begin(), layerLo.end());
    const float maximum = *std::max_element(layerHi.begin(), layerHi.end());
    if (range) *range = {minimum, maximum};
    const float insideValue = insideAbove ? maximum : minimum, outsideValue = insideAbove ? minimum : maximum;
    auto grid = openvdb::FloatGrid::create(outsideValue);
    grid->setTransform(transformOf(v.indexToWorld));
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    grid->insertMeta("isoforge_inside", openvdb::StringMetadata(insideAbove ? "above" : "below"));
    grid->insertMeta("source_format", openvdb::StringMetadata(v.format));
    using Leaf = openvdb::FloatGrid::TreeType::LeafNodeType;
    openvdb::FloatGrid::TreeType& tree = grid->tree();
    std::vector<Leaf*> leaves;
    for (std::int64_t K = 0; K < bz; ++K)
        for (std::int64_t J = 0; J < by; ++J)
            for (std::int64_t I = 0; I < bx; ++I) {
                const std::uint8_t c = kind[std::size_t((K * by + J) * bx + I)];
                const openvdb::Coord o(int(8 * I), int(8 * J), int(8 * K));
                if (c == 1) tree.addTile(1, o, insideValue, true);
                if (c == 2) leaves.push_back(tree.touchLeaf(o));
            }
    tbb::parallel_for(std::size_t{0}, leaves.size(), [&](std::size_t n) {
        Leaf& leaf = *leaves[n];
        const openvdb::Coord o = leaf.origin();
        if (o.x() + 8 <= nx && o.y() + 8 <= ny && o.z() + 8 <= nz) {  // wholly in the array: rows of 8 at once
            float* buffer = leaf.buffer().data();                     // x slowest, z fastest
            for (int dz = 0; dz < 8; ++dz)
                for (int dy = 0; dy < 8; ++dy) {
                    const float* row = v.values + std::size_t(((o.z() + dz) * ny + o.y() + dy) * nx + o.x());
                    for (int dx = 0; dx < 8; ++dx) buffer[(dx << 6) | (dy << 3) | dz] = row[dx];
                }
            leaf.setValuesOn();
            return;
        }
        for (int dz = 0; dz < 8; ++dz)
            for (int dy = 0; dy < 8; ++dy)
                for (int dx = 0; dx < 8; ++dx) {
                    const std::int64_t i = o.x() + dx, j = o.y() + dy, k = o.z() + dz;
                    const openvdb::Index offset = Leaf::coordToOffset(openvdb::Coord(int(i), int(j), int(k)));
                    if (i < nx && j < ny && k < nz)
                        leaf.setValueOn(offset, at(i, j, k));
                    else
                        leaf.setValueOff(offset, outsideValue);
                }
    });
    return grid;
}

DenseVolume toDense(const openvdb::FloatGrid& grid, const std::filesystem::path& source) {
    const openvdb::CoordBBox box = grid.evalActiveVoxelBoundingBox();
    DenseVolume v;
    v.format = "VDB";
    v.storedType = "float32";
    const std::string what = (source.empty() ? "" : source.string() + ": ") + "grid '" + grid.getName() + "'";
    if (box.empty()) throw IoError(what + " has no active voxels");
    const openvdb::Coord d = box.dim();
    v.dims = {d.x(), d.y(), d.z()};
    // A few bytes of active tiles can span 4096^3 voxels: refuse before allocating, with the estimate.
    detail::checkVolumeSize(what, v.dims);
    resizeLarge(v.values, std::size_t(v.voxelCount()));
    openvdb::tools::Dense<float, openvdb::tools::LayoutXYZ> dense(box, v.values.data());
    openvdb::tools::copyToDense(grid, dense);
    if (!grid.transform().isLinear()) throw IoError(what + " has a non-linear transform");
    const openvdb::Mat4d m = grid.transform().baseMap()->getAffineMap()->getMat4();
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) v.indexToWorld[i][j] = m[i][j];
    // Index (0,0,0) of the dense volume is the box's minimum corner.
    const glm::dvec4 shift = v.indexToWorld * glm::dvec4(box.min().x(), box.min().y(), box.min().z(), 1.0);
    v.indexToWorld[3] = shift;
    v.notes.push_back("grid '" + grid.getName() + "', active bounding box of " +
                      std::to_string(grid.activeVoxelCount()) + " active voxels");
    return v;
}

namespace detail {
DenseVolume readVdbVolume(const std::filesystem::path& path, const std::string& name) {
    auto grid = readFloatGrid(path, name.empty() ? std::nullopt : std::optional(name));
    DenseVolume v = toDense(*grid, path);
    return v;
}
}  // namespace detail

}  // namespace isoforge::volume
