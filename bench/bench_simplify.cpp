// Simplification side by side: isoforge's mesh::simplify (`--max-error`) against meshoptimizer's
// meshopt_simplify (Debian 0.18) on the same mesh and the same absolute error bound (meshoptimizer's
// target error is relative: the bound divided by meshopt_simplifyScale; no target count, so each goes as
// far as its bound allows). For each: time, input triangles per second, triangles kept, the measured
// Hausdorff distance to the input (exact distances to the other mesh's triangles, at the vertices and at
// 21 points on every triangle: from the input's vertices, back from the result, and both ways), and
// whether the result is still closed, manifold, oriented and free of intersecting pairs (mesh::check with
// exact predicates).
// Usage: bench_simplify MAX_ERROR MESH...   (meshes made by `isoforge mesh`, e.g. --sharp; docs/performance.md)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <meshoptimizer.h>
#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>

#include "csg/shapes.h"
#include "mesh/check.h"
#include "mesh/io.h"
#include "mesh/simplify.h"

using namespace isoforge;

namespace {

/// The farthest of `from`'s vertices (and, with `inside`, of points a fifth of each edge apart on every
/// triangle: 21 a triangle) from the surface `to`.
double farthest(const mesh::TriMesh& from, const implicit::FieldPtr& to, bool inside) {
    std::vector<glm::vec3> pts = from.positions;
    for (const auto& t : inside ? from.triangles : std::vector<glm::uvec3>{}) {
        const glm::vec3 a = from.positions[t.x], b = from.positions[t.y], c = from.positions[t.z];
        for (int i = 0; i <= 5; ++i)
            for (int j = 0; i + j <= 5; ++j) pts.push_back(a + (b - a) * (float(i) / 5.f) + (c - a) * (float(j) / 5.f));
    }
    std::vector<double> d(pts.size());
    tbb::parallel_for(std::size_t{0}, pts.size(), [&](std::size_t i) { d[i] = std::abs(to->value(pts[i])); });
    return d.empty() ? 0.0 : *std::max_element(d.begin(), d.end());
}

mesh::TriMesh meshoptSimplify(const mesh::TriMesh& in, double maxError, float& resultError) {
    std::vector<unsigned> indices;
    for (const auto& t : in.triangles) indices.insert(indices.end(), {t.x, t.y, t.z});
    const float* xyz = &in.positions[0].x;
    const float scale = meshopt_simplifyScale(xyz, in.positions.size(), sizeof(glm::vec3));
    std::vector<unsigned> out(indices.size());
    const std::size_t n = meshopt_simplify(out.data(), indices.data(), indices.size(), xyz, in.positions.size(),
                                           sizeof(glm::vec3), 0, float(maxError / scale), 0, &resultError);
    resultError *= scale;
    mesh::TriMesh m;
    std::vector<std::int64_t> remap(in.positions.size(), -1);
    for (std::size_t i = 0; i < n; i += 3) {
        glm::uvec3 t;
        for (int k = 0; k < 3; ++k) {
            const unsigned v = out[i + std::size_t(k)];
            if (remap[v] < 0) {
                remap[v] = std::int64_t(m.positions.size());
                m.positions.push_back(in.positions[v]);
            }
            t[k] = unsigned(remap[v]);
        }
        m.triangles.push_back(t);
    }
    return m;
}

}  // namespace

int main(int argc, char** argv) {
    const char* usage = "Usage: bench_simplify MAX_ERROR MESH...";
    if (argc < 3) {
        std::fprintf(stderr, "%s\n", usage);
        return 2;
    }
    char* end = nullptr;
    const double maxError = std::strtod(argv[1], &end);
    if (*end != '\0' || !(maxError > 0)) {
        std::fprintf(stderr, "bench_simplify: MAX_ERROR must be a positive number\n%s\n", usage);
        return 2;
    }
    std::printf(
        "| mesh | simplifier | input triangles | seconds | input triangles/s | triangles kept | "
        "Hausdorff (bound %g): vertices / back / all | closed, manifold, oriented | intersecting pairs |\n",
        maxError);
    std::printf("|---|---|---:|---:|---:|---:|---:|---|---:|\n");
    for (int i = 2; i < argc; ++i) {
        const std::string path = argv[i];
        const mesh::TriMesh full = mesh::readMesh(path);
        const auto toFull = csg::makeTriangleMeshField(full.positions, full.triangles, "full", nullptr, true);
        double ours = 0;
        for (const char* who : {"isoforge", "meshoptimizer"}) {
            mesh::TriMesh m = full;
            float reported = 0;
            const auto t0 = std::chrono::steady_clock::now();
            if (who[0] == 'i')
                mesh::simplify(m, maxError);
            else
                m = meshoptSimplify(full, maxError, reported);
            const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            if (who[0] == 'i') ours = s;
            mesh::CheckOptions co;
            co.selfIntersections = true;
            const mesh::MeshReport r = mesh::check(m, co);
            const auto toSimple = csg::makeTriangleMeshField(m.positions, m.triangles, "simplified");
            const double vertices = farthest(full, toSimple, false), back = farthest(m, toFull, true);
            const double haus = std::max({vertices, back, farthest(full, toSimple, true)});
            const bool closed = r.isWatertight() && r.isVertexManifold() && r.isOriented() && !r.hasDegenerates();
            std::printf("| %s | %s | %zu | %.2f | %.0f | %zu | %.4f / %.4f / %.4f | %s | %zu |\n", path.c_str(), who,
                        full.triangles.size(), s, double(full.triangles.size()) / s, m.triangles.size(), vertices, back,
                        haus, closed ? "yes" : "no", r.selfIntersections.pairs);
            if (who[0] == 'm')
                std::printf("| | meshoptimizer / isoforge time: %.3fx (its own error estimate %.4f) | | | | | | | |\n",
                            s / ours, reported);
            std::fflush(stdout);
        }
    }
    return 0;
}
