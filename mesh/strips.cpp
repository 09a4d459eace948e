#include "mesh/strips.h"

#include <algorithm>
#include <cstdio>
#include <string>

#include <meshoptimizer.h>

#include "core/atomic_file.h"

namespace isoforge::mesh {

double Strips::verticesPerTriangle() const {
    const auto sent = static_cast<double>(
        std::count_if(indices.begin(), indices.end(), [](std::uint32_t i) { return i != kRestart; }));
    return triangleCount ? sent / static_cast<double>(triangleCount) : 0.0;
}

Strips makeStrips(const TriMesh& mesh) {
    Strips s;
    s.triangleCount = mesh.triangles.size();
    if (mesh.triangles.empty()) return s;
    const std::size_t n = mesh.triangles.size() * 3;
    const auto* flat = reinterpret_cast<const std::uint32_t*>(mesh.triangles.data());
    std::vector<std::uint32_t> ordered(n);
    meshopt_optimizeVertexCache(ordered.data(), flat, n, mesh.positions.size());
    s.indices.resize(meshopt_stripifyBound(n));
    s.indices.resize(meshopt_stripify(s.indices.data(), ordered.data(), n, mesh.positions.size(), Strips::kRestart));
    s.stripCount = s.indices.empty()
                       ? 0
                       : 1 + static_cast<std::size_t>(std::count(s.indices.begin(), s.indices.end(), Strips::kRestart));
    return s;
}

std::vector<glm::uvec3> expandStrips(const Strips& strips) {
    std::vector<std::uint32_t> flat(meshopt_unstripifyBound(strips.indices.size()));
    flat.resize(meshopt_unstripify(flat.data(), strips.indices.data(), strips.indices.size(), Strips::kRestart));
    std::vector<glm::uvec3> out;
    out.reserve(flat.size() / 3);
    for (std::size_t i = 0; i + 2 < flat.size(); i += 3) out.emplace_back(flat[i], flat[i + 1], flat[i + 2]);
    return out;
}

bool sameTriangles(std::vector<glm::uvec3> a, std::vector<glm::uvec3> b) {
    auto canonical = [](std::vector<glm::uvec3>& v) {
        for (auto& t : v) {
            // Rotate so the smallest index comes first: the same oriented triangle, one spelling.
            while (t.x > t.y || t.x > t.z) t = glm::uvec3(t.y, t.z, t.x);
        }
        std::sort(v.begin(), v.end(), [](const glm::uvec3& p, const glm::uvec3& q) {
            return std::tie(p.x, p.y, p.z) < std::tie(q.x, q.y, q.z);
        });
    };
    canonical(a);
    canonical(b);
    return a == b;
}

void writeStrips(const std::filesystem::path& path, const TriMesh& mesh, const Strips& strips) {
    std::string text = "# isoforge triangle strips: " + std::to_string(mesh.positions.size()) + " vertices, " +
                       std::to_string(strips.stripCount) + " strips, " + std::to_string(strips.triangleCount) +
                       " triangles\n";
    char buf[96];
    for (const auto& p : mesh.positions) {
        std::snprintf(buf, sizeof buf, "v %.9g %.9g %.9g\n", p.x, p.y, p.z);
        text += buf;
    }
    bool open = false;
    for (std::uint32_t i : strips.indices) {
        if (i == Strips::kRestart) {
            if (open) text += '\n';
            open = false;
            continue;
        }
        text += open ? " " : "s ";
        text += std::to_string(i);
        open = true;
    }
    if (open) text += '\n';
    AtomicFile file(path);
    file.write(text.data(), text.size());
    file.commit();
}

}  // namespace isoforge::mesh
