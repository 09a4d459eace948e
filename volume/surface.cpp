#include "volume/surface.h"

#include <stdexcept>
#include <vector>

#include <tbb/parallel_for.h>
#include <glm/common.hpp>

namespace isoforge::volume {

namespace {

glm::vec3 toWorld(const openvdb::math::Transform& xform, const glm::vec3& p) {
    const openvdb::Vec3d w = xform.indexToWorld(openvdb::Vec3d(p.x, p.y, p.z));
    return glm::vec3(float(w.x()), float(w.y()), float(w.z()));
}

/// Colours of the field's CSG colour nodes, per vertex (white where none is given); none when no node gives one.
void colourByMaterial(mesh::TriMesh& m, const implicit::Field& field) {
    if (m.empty() || field.colorAt(m.positions.front()).a < 0.f) return;
    m.colors.resize(m.positions.size());
    tbb::parallel_for(std::size_t{0}, m.positions.size(), [&](std::size_t i) {
        const glm::vec4 col = field.colorAt(m.positions[i]);
        m.colors[i] = col.a > 0 ? glm::vec3(col) : glm::vec3(1.f);
    });
    bool any = false;
    for (const auto& col : m.colors) any = any || col != glm::vec3(1.f);
    if (!any) m.colors.clear();
}

}  // namespace

mesh::TriMesh meshSurface(const openvdb::FloatGrid& grid, const implicit::FieldPtr& field,
                          const SurfaceOptions& options, SurfaceStats* stats) {
    if (options.maxError > 0 && options.indexSpace)
        throw std::invalid_argument("the simplification bound is in world units: not with index-space positions");
    SurfaceStats local;
    SurfaceStats& st = stats ? *stats : local;
    MeshingOptions opt;
    opt.isovalue = options.isovalue;
    opt.inside = options.inside;
    opt.normals = options.normals;
    opt.worldSpace = !options.indexSpace && !options.sharp;
    opt.progress = options.progress;
    mesh::TriMesh m = extractIsosurface(grid, opt, &st.meshing);
    if (options.sharp) {
        const openvdb::math::Transform& xform = grid.transform();
        if (field) {
            // Each batch evaluates the field pruned to its box (CSG children that cannot reach it dropped).
            auto pruned = [&field, &xform](const glm::vec3& lo, const glm::vec3& hi) -> IndexValues {
                implicit::Box3 box;
                for (int c = 0; c < 8; ++c) {
                    const glm::vec3 w =
                        toWorld(xform, glm::vec3(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z));
                    box.min = glm::min(box.min, w);
                    box.max = glm::max(box.max, w);
                }
                const implicit::FieldPtr f = implicit::simplified(field, box);
                return [f, &xform](std::span<const glm::vec3> p, std::span<float> out) {
                    std::vector<glm::vec3> world(p.size());
                    for (std::size_t i = 0; i < p.size(); ++i) world[i] = toWorld(xform, p[i]);
                    f->values(world, out);
                };
            };
            sharpen(m, pruned, &st.sharpen);
        } else {
            sharpenWithGrid(m, grid, options.isovalue, insideIsBelow(grid, options.inside), &st.sharpen);
        }
        if (!options.indexSpace)
            tbb::parallel_for(std::size_t{0}, m.positions.size(),
                              [&](std::size_t i) { m.positions[i] = toWorld(xform, m.positions[i]); });
    }
    st.fullTriangles = m.triangleCount();
    if (options.maxError > 0) st.simplify = mesh::simplify(m, options.maxError);
    if (field && !options.indexSpace) colourByMaterial(m, *field);
    return m;
}

}  // namespace isoforge::volume
