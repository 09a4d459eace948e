#include "mesh/subdivide.h"

#include <cmath>
#include <unordered_map>

#include "mesh/halfedge.h"

namespace isoforge::mesh {

TriMesh loopSubdivide(const TriMesh& in) {
    const HalfEdgeMesh h(in);
    TriMesh out;
    const std::size_t nv = in.positions.size();
    out.positions.resize(nv);
    // Even (old) vertices.
    for (std::uint32_t v = 0; v < nv; ++v) {
        const auto ring = h.oneRing(v);
        const glm::vec3 p = in.positions[v];
        if (ring.empty()) {
            out.positions[v] = p;
        } else if (h.isBoundaryVertex(v)) {
            out.positions[v] = 0.75f * p + 0.125f * (in.positions[ring.front()] + in.positions[ring.back()]);
        } else {
            const double k = double(ring.size());
            const double c = 3.0 / 8.0 + 0.25 * std::cos(2.0 * M_PI / k);
            const auto beta = static_cast<float>((5.0 / 8.0 - c * c) / k);
            glm::vec3 sum(0.f);
            for (std::uint32_t w : ring) sum += in.positions[w];
            out.positions[v] = (1.f - float(k) * beta) * p + beta * sum;
        }
    }
    // Odd (edge) vertices, one per undirected edge.
    std::unordered_map<std::uint64_t, std::uint32_t> edgeVertex;
    edgeVertex.reserve(in.triangles.size() * 3 / 2 + 1);
    auto odd = [&](std::uint32_t he) {
        const std::uint32_t a = h.from(he), b = h.halfEdge(he).to;
        const std::uint64_t key = (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
        auto [it, added] = edgeVertex.try_emplace(key, 0u);
        if (added) {
            const glm::vec3 pa = in.positions[a], pb = in.positions[b];
            const std::uint32_t t = h.halfEdge(he).twin;
            glm::vec3 p;
            if (t == HalfEdgeMesh::kNone) {
                p = 0.5f * (pa + pb);
            } else {
                const glm::vec3 c = in.positions[h.halfEdge(HalfEdgeMesh::next(he)).to];
                const glm::vec3 d = in.positions[h.halfEdge(HalfEdgeMesh::next(t)).to];
                p = 0.375f * (pa + pb) + 0.125f * (c + d);
            }
            it->second = static_cast<std::uint32_t>(out.positions.size());
            out.positions.push_back(p);
        }
        return it->second;
    };
    out.triangles.reserve(in.triangles.size() * 4);
    for (std::uint32_t f = 0; f < in.triangles.size(); ++f) {
        const glm::uvec3& t = in.triangles[f];
        const std::uint32_t ab = odd(3 * f), bc = odd(3 * f + 1), ca = odd(3 * f + 2);
        out.triangles.insert(out.triangles.end(), {{t.x, ab, ca}, {t.y, bc, ab}, {t.z, ca, bc}, {ab, bc, ca}});
    }
    return out;
}

}  // namespace isoforge::mesh
