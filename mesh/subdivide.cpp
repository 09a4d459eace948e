#include "mesh/subdivide.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "mesh/halfedge.h"

namespace isoforge::mesh {

namespace {
/// Every triangle into four, around the edge vertices `odd(halfEdge)` makes (one per edge).
template <class Odd>
void splitInFour(const TriMesh& in, TriMesh& out, Odd&& odd) {
    out.triangles.reserve(in.triangles.size() * 4);
    for (std::uint32_t f = 0; f < in.triangles.size(); ++f) {
        const glm::uvec3& t = in.triangles[f];
        const std::uint32_t ab = odd(3 * f), bc = odd(3 * f + 1), ca = odd(3 * f + 2);
        out.triangles.insert(out.triangles.end(), {{t.x, ab, ca}, {t.y, bc, ab}, {t.z, ca, bc}, {ab, bc, ca}});
    }
}
}  // namespace

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
    splitInFour(in, out, odd);
    return out;
}

namespace {

/// The vertex across the edge of half-edge h, in the face on its other side; kNone on the boundary.
std::uint32_t across(const HalfEdgeMesh& h, std::uint32_t he) {
    const std::uint32_t t = h.halfEdge(he).twin;
    return t == HalfEdgeMesh::kNone ? HalfEdgeMesh::kNone : h.halfEdge(HalfEdgeMesh::next(t)).to;
}

/// Zorin's stencil around an extraordinary vertex v (valence k) for its edge towards w.
glm::vec3 extraordinary(const HalfEdgeMesh& h, const TriMesh& in, std::uint32_t v, std::uint32_t w) {
    const auto ring = h.oneRing(v);
    const std::size_t k = ring.size();
    const std::size_t start = static_cast<std::size_t>(std::find(ring.begin(), ring.end(), w) - ring.begin());
    glm::dvec3 p = 0.75 * glm::dvec3(in.positions[v]);
    for (std::size_t j = 0; j < k; ++j) {
        double s;
        if (k == 3)
            s = j == 0 ? 5.0 / 12.0 : -1.0 / 12.0;
        else if (k == 4)
            s = j == 0 ? 3.0 / 8.0 : (j == 2 ? -1.0 / 8.0 : 0.0);
        else
            s = (0.25 + std::cos(2.0 * M_PI * double(j) / double(k)) +
                 0.5 * std::cos(4.0 * M_PI * double(j) / double(k))) /
                double(k);
        p += s * glm::dvec3(in.positions[ring[(start + j) % k]]);
    }
    return glm::vec3(p);
}

}  // namespace

TriMesh butterflySubdivide(const TriMesh& in) {
    const HalfEdgeMesh h(in);
    TriMesh out;
    out.positions = in.positions;  // interpolating: old vertices stay
    std::unordered_map<std::uint64_t, std::uint32_t> edgeVertex;
    edgeVertex.reserve(in.triangles.size() * 3 / 2 + 1);
    auto P = [&](std::uint32_t v) { return glm::dvec3(in.positions[v]); };
    // The neighbour of boundary vertex v along the boundary, away from u.
    auto boundaryNext = [&](std::uint32_t v, std::uint32_t u) {
        const auto ring = h.oneRing(v);
        return ring.front() == u ? ring.back() : ring.front();
    };
    auto odd = [&](std::uint32_t he) {
        const std::uint32_t a = h.from(he), b = h.halfEdge(he).to;
        const std::uint64_t key = (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
        auto [it, added] = edgeVertex.try_emplace(key, 0u);
        if (!added) return it->second;
        const std::uint32_t t = h.halfEdge(he).twin;
        glm::dvec3 p;
        if (t == HalfEdgeMesh::kNone) {
            // Boundary edge: the 4-point scheme along the boundary.
            p = 9.0 / 16.0 * (P(a) + P(b)) - 1.0 / 16.0 * (P(boundaryNext(a, b)) + P(boundaryNext(b, a)));
        } else {
            const std::uint32_t c = h.halfEdge(HalfEdgeMesh::next(he)).to, d = h.halfEdge(HalfEdgeMesh::next(t)).to;
            const std::size_t ka = h.valence(a), kb = h.valence(b);
            const bool ba = h.isBoundaryVertex(a), bb = h.isBoundaryVertex(b);
            // The butterfly's wings: across the four outer edges of the two triangles.
            const std::uint32_t e1 = across(h, HalfEdgeMesh::next(he)), e2 = across(h, HalfEdgeMesh::prev(he)),
                                e3 = across(h, HalfEdgeMesh::next(t)), e4 = across(h, HalfEdgeMesh::prev(t));
            const bool wings = e1 != HalfEdgeMesh::kNone && e2 != HalfEdgeMesh::kNone && e3 != HalfEdgeMesh::kNone &&
                               e4 != HalfEdgeMesh::kNone;
            if (ba || bb || !wings) {
                p = 9.0 / 16.0 * (P(a) + P(b)) - 1.0 / 16.0 * (P(c) + P(d));  // near the boundary: 4-point across
            } else if (ka == 6 && kb == 6) {
                p = 0.5 * (P(a) + P(b)) + 0.125 * (P(c) + P(d)) - 1.0 / 16.0 * (P(e1) + P(e2) + P(e3) + P(e4));
            } else if (ka != 6 && kb == 6) {
                p = glm::dvec3(extraordinary(h, in, a, b));
            } else if (ka == 6) {
                p = glm::dvec3(extraordinary(h, in, b, a));
            } else {
                p = 0.5 * (glm::dvec3(extraordinary(h, in, a, b)) + glm::dvec3(extraordinary(h, in, b, a)));
            }
        }
        it->second = static_cast<std::uint32_t>(out.positions.size());
        out.positions.push_back(glm::vec3(p));
        return it->second;
    };
    splitInFour(in, out, odd);
    return out;
}

}  // namespace isoforge::mesh
