#include "volume/voxelize.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include <openvdb/tools/MeshToVolume.h>

#include "core/error.h"
#include "mesh/check.h"
#include "volume/sample.h"
#include "volume/vdb_io.h"

namespace isoforge::volume {

VoxelizeResult voxelize(const mesh::TriMesh& m, const VoxelizeOptions& o) {
    initializeOpenVdb();
    if (m.triangles.empty()) throw std::invalid_argument("voxelize: the mesh has no triangles");
    if (!(o.voxelSize > 0)) throw std::invalid_argument("voxelize: the voxel size must be positive");
    // The band holds about (surface area / voxel^2) x (2 half-widths) voxels, in 8^3 leaves of 2 KiB+.
    const double area = mesh::area(m);
    const double voxels = area / (double(o.voxelSize) * o.voxelSize) * 2.0 * o.halfWidth;
    const double bytes = voxels * 4.0 * 2.0;  // values plus node overhead, roughly
    if (bytes > 0.5 * double(physicalMemory()))
        throw ResourceError("voxelizing at voxel " + std::to_string(o.voxelSize) + " would need about " +
                            std::to_string(static_cast<long long>(bytes / (1 << 20))) +
                            " MiB, more than half of this machine's memory: use a larger --voxel");
    std::vector<openvdb::Vec3s> points;
    points.reserve(m.positions.size());
    for (const auto& p : m.positions) points.emplace_back(p.x, p.y, p.z);
    std::vector<openvdb::Vec3I> tris;
    tris.reserve(m.triangles.size());
    for (const auto& t : m.triangles) tris.emplace_back(t.x, t.y, t.z);
    const auto xform = openvdb::math::Transform::createLinearTransform(o.voxelSize);
    const mesh::MeshReport report = mesh::check(m);
    VoxelizeResult r;
    r.isSigned = report.boundaryEdges == 0 && report.nonManifoldEdges == 0;
    if (r.isSigned) {
        r.grid = openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(*xform, points, tris, o.halfWidth);
    } else {
        const std::vector<openvdb::Vec4I> quads;
        r.grid =
            openvdb::tools::meshToUnsignedDistanceField<openvdb::FloatGrid>(*xform, points, tris, quads, o.halfWidth);
        r.grid->setGridClass(openvdb::GRID_UNKNOWN);
    }
    r.grid->insertMeta("isoforge_inside", openvdb::StringMetadata("below"));
    r.grid->setName(r.isSigned ? "level_set" : "unsigned_distance");
    return r;
}

}  // namespace isoforge::volume
