// isoforge compare: how far one mesh lies from another (a reference): surface distances both ways,
// Hausdorff, and the distance from the reference's sharp edges, for fidelity benchmarks.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <vector>

#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>

#include "app/commands.h"
#include "core/error.h"
#include "csg/shapes.h"
#include "mesh/io.h"

namespace isoforge::app {

namespace {

struct Distances {
    std::size_t points = 0;
    double mean = 0, p90 = 0, max = 0;
    glm::vec3 worst{0.f};  ///< the point farthest away
};

/// Distances from `points` to the surface of `to` (the exact distance to its triangles).
Distances distancesTo(const implicit::FieldPtr& to, const std::vector<glm::vec3>& points) {
    std::vector<double> d(points.size());
    tbb::parallel_for(std::size_t{0}, points.size(), [&](std::size_t i) { d[i] = std::abs(to->value(points[i])); });
    Distances r;
    r.points = d.size();
    if (d.empty()) return r;
    for (double x : d) r.mean += x;
    r.mean /= double(d.size());
    const auto far = std::max_element(d.begin(), d.end());
    r.max = *far;
    r.worst = points[std::size_t(far - d.begin())];
    std::nth_element(d.begin(), d.begin() + std::ptrdiff_t(d.size() * 9 / 10), d.end());
    r.p90 = d[d.size() * 9 / 10];
    return r;
}

/// Points on every triangle no more than `spacing` apart (its vertices and a barycentric grid), the
/// spacing widened so that there are at most about `budget` of them.
std::vector<glm::vec3> surfacePoints(const mesh::TriMesh& m, double spacing, double budget = 2e6) {
    double area = 0;
    for (const auto& t : m.triangles)
        area += 0.5 * glm::length(glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x]));
    spacing = std::max(spacing, std::sqrt(2.0 * area / budget));
    std::vector<glm::vec3> pts;
    for (const auto& t : m.triangles) {
        const glm::vec3 a = m.positions[t.x], b = m.positions[t.y], c = m.positions[t.z];
        const double longest = std::max({glm::length(b - a), glm::length(c - b), glm::length(a - c)});
        const int n = std::clamp(int(std::ceil(longest / spacing)), 1, 4000);
        for (int i = 0; i <= n; ++i)
            for (int j = 0; i + j <= n; ++j) {
                const float u = float(i) / float(n), v = float(j) / float(n);
                pts.push_back(a + u * (b - a) + v * (c - a));
            }
    }
    return pts;
}

/// Points along the edges of `m` whose two triangles' normals are more than `angle` degrees apart.
std::vector<glm::vec3> sharpEdgePoints(const mesh::TriMesh& m, double angle, double spacing, std::size_t& edges) {
    std::map<std::tuple<float, float, float>, unsigned> ids;
    std::vector<unsigned> id(m.positions.size());
    for (std::size_t i = 0; i < m.positions.size(); ++i)
        id[i] = ids.emplace(std::make_tuple(m.positions[i].x, m.positions[i].y, m.positions[i].z), unsigned(i))
                    .first->second;
    std::map<std::pair<unsigned, unsigned>, std::vector<glm::vec3>> normals;
    for (const auto& t : m.triangles) {
        const unsigned v[3] = {id[t.x], id[t.y], id[t.z]};
        const glm::vec3 n = glm::cross(m.positions[v[1]] - m.positions[v[0]], m.positions[v[2]] - m.positions[v[0]]);
        if (!(glm::length(n) > 0)) continue;
        for (int k = 0; k < 3; ++k)
            normals[{std::min(v[k], v[(k + 1) % 3]), std::max(v[k], v[(k + 1) % 3])}].push_back(glm::normalize(n));
    }
    const double cosine = std::cos(angle * M_PI / 180.0);
    std::vector<glm::vec3> pts;
    edges = 0;
    for (const auto& [e, ns] : normals) {
        if (ns.size() != 2 || !(glm::dot(ns[0], ns[1]) < cosine)) continue;
        ++edges;
        const glm::vec3 a = m.positions[e.first], b = m.positions[e.second];
        const int n = std::clamp(int(std::ceil(glm::length(b - a) / spacing)), 1, 100000);
        for (int i = 0; i <= n; ++i) pts.push_back(a + (b - a) * (float(i) / float(n)));
    }
    return pts;
}

}  // namespace

void addCompareCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    struct Args {
        std::string mesh, reference;
        double voxel = 0, angle = 30;
    };
    auto a = std::make_shared<Args>();
    auto* cmd = app.add_subcommand(
        "compare",
        "How far a mesh lies from a reference mesh: both ways, Hausdorff, and from the reference's sharp edges");
    cmd->add_option("mesh", a->mesh, "The mesh to measure (.ply .obj .stl .off)")->required();
    cmd->add_option("reference", a->reference, "The reference mesh (for example OpenSCAD's STL)")->required();
    cmd->add_option("--voxel", a->voxel, "Also give distances in voxels of this size; samples are voxel/4 apart")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--angle", a->angle, "Sharp edges: normals more than this many degrees apart (default 30)")
        ->check(CLI::Range(1.0, 179.0));
    cmd->callback([&c, &g, a] {
        c.run = [&g, a] {
            const mesh::TriMesh m = mesh::readMesh(a->mesh), ref = mesh::readMesh(a->reference);
            auto field = [](const mesh::TriMesh& t, const std::string& name) {
                try {
                    // Only the distance is used: closed meshes take the cheap pseudonormal sign.
                    return csg::makeTriangleMeshField(t.positions, t.triangles, name, nullptr, true);
                } catch (const std::invalid_argument& e) {
                    throw IoError(name + ": " + e.what());
                }
            };
            const implicit::FieldPtr fm = field(m, a->mesh), fr = field(ref, a->reference);
            const glm::vec3 size = fr->bounds().size();
            const double spacing = (a->voxel > 0 ? a->voxel : std::max({size.x, size.y, size.z}) / 256.0) / 4.0;
            std::vector<glm::vec3> mine = surfacePoints(m, spacing), theirs = surfacePoints(ref, spacing);
            std::size_t sharpEdges = 0;
            const std::vector<glm::vec3> creases = sharpEdgePoints(ref, a->angle, spacing, sharpEdges);
            const Distances out = distancesTo(fr, mine), in = distancesTo(fm, theirs), edge = distancesTo(fm, creases);
            const double unit = a->voxel > 0 ? a->voxel : 1.0;
            const char* u = a->voxel > 0 ? "voxels" : "units";
            std::printf("triangles        %zu (reference %zu)\n", m.triangleCount(), ref.triangleCount());
            auto line = [&](const char* what, const Distances& d) {
                std::printf("%-16s mean %.4f  p90 %.4f  max %.4f %s at (%g, %g, %g)  (%zu points)\n", what,
                            d.mean / unit, d.p90 / unit, d.max / unit, u, d.worst.x, d.worst.y, d.worst.z, d.points);
            };
            line("to reference", out);
            line("from reference", in);
            std::printf("hausdorff        %.4f %s\n", std::max(out.max, in.max) / unit, u);
            if (sharpEdges)
                line("sharp edges", edge);
            else
                std::printf("sharp edges      none (no edge of the reference bends by more than %g degrees)\n",
                            a->angle);
            (void)g;
            return 0;
        };
    });
}

}  // namespace isoforge::app
