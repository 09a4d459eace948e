#include "volume/dense_grid.h"

#include <algorithm>
#include <stdexcept>

#include <openvdb/tools/Dense.h>

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
