#include "volume/surface_box.h"

#include "volume/marching_cubes.h"
#include "volume/sample.h"

namespace isoforge::volume {

implicit::Box3 surfaceBox(const implicit::FieldPtr& field, const implicit::Box3& clip, int resolution) {
    const implicit::Box3 domain = sampleDomain(*field, clip);
    if (domain.isEmpty() || !domain.isBounded()) return domain;
    SampleOptions so;
    so.voxelSize = voxelSizeForResolution(domain, resolution);
    so.clip = clip;
    const mesh::TriMesh m = extractIsosurface(*sample(field, so), MeshingOptions{});
    implicit::Box3 box;
    for (const auto& p : m.positions) box = box.unite(implicit::Box3{p, p});
    return box;
}

implicit::Box3 framingBox(const implicit::FieldPtr& field, const implicit::Box3& clip) {
    const implicit::Box3 domain = sampleDomain(*field, clip);
    if (domain.isEmpty()) return {glm::vec3(-1.f), glm::vec3(1.f)};
    if (!domain.isBounded()) return domain;
    const implicit::Box3 surface = surfaceBox(field, clip, 128);
    return surface.isEmpty() ? domain : surface;
}

}  // namespace isoforge::volume
