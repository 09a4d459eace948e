#include "mesh/subdivide.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <unordered_set>

#include <glm/geometric.hpp>

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

namespace {

std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b) {
    return (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
}

/// One level of Loop's scheme. `sharp` holds the crease edges (boundary edges are always sharp); the
/// crease edges of the result (the halves of these) are returned in it.
TriMesh loopStep(const TriMesh& in, std::unordered_set<std::uint64_t>& sharp) {
    const HalfEdgeMesh h(in);
    TriMesh out;
    const std::size_t nv = in.positions.size();
    out.positions.resize(nv);
    auto isSharp = [&](std::uint32_t a, std::uint32_t b) { return sharp.count(edgeKey(a, b)) != 0; };
    // Even (old) vertices: smooth (Loop's beta), crease (two sharp edges, or a boundary: the cubic
    // B-spline rule along them) or corner (three or more: fixed).
    for (std::uint32_t v = 0; v < nv; ++v) {
        const auto ring = h.oneRing(v);
        const glm::vec3 p = in.positions[v];
        std::uint32_t along[2] = {0, 0};
        std::size_t sharpCount = 0;
        const bool boundary = !ring.empty() && h.isBoundaryVertex(v);
        if (boundary) {
            along[0] = ring.front();
            along[1] = ring.back();
            sharpCount = 2;
        }
        for (std::size_t i = 0; i < ring.size(); ++i) {
            if (boundary && (i == 0 || i + 1 == ring.size())) continue;
            if (isSharp(v, ring[i])) {
                if (sharpCount < 2) along[sharpCount] = ring[i];
                ++sharpCount;
            }
        }
        if (ring.empty() || sharpCount >= 3) {
            out.positions[v] = p;
        } else if (sharpCount == 2) {
            out.positions[v] = 0.75f * p + 0.125f * (in.positions[along[0]] + in.positions[along[1]]);
        } else {  // smooth, or a dart (one crease edge ending here): Loop's rule
            const double k = double(ring.size());
            const double c = 3.0 / 8.0 + 0.25 * std::cos(2.0 * M_PI / k);
            const auto beta = static_cast<float>((5.0 / 8.0 - c * c) / k);
            glm::vec3 sum(0.f);
            for (std::uint32_t w : ring) sum += in.positions[w];
            out.positions[v] = (1.f - float(k) * beta) * p + beta * sum;
        }
    }
    // Odd (edge) vertices, one per undirected edge: midpoints of sharp edges, 3/8 3/8 1/8 1/8 elsewhere.
    std::unordered_map<std::uint64_t, std::uint32_t> edgeVertex;
    edgeVertex.reserve(in.triangles.size() * 3 / 2 + 1);
    std::unordered_set<std::uint64_t> nextSharp;
    auto odd = [&](std::uint32_t he) {
        const std::uint32_t a = h.from(he), b = h.halfEdge(he).to;
        auto [it, added] = edgeVertex.try_emplace(edgeKey(a, b), 0u);
        if (added) {
            const glm::vec3 pa = in.positions[a], pb = in.positions[b];
            const std::uint32_t t = h.halfEdge(he).twin;
            const auto m = static_cast<std::uint32_t>(out.positions.size());
            if (t == HalfEdgeMesh::kNone || isSharp(a, b)) {
                out.positions.push_back(0.5f * (pa + pb));
                if (t != HalfEdgeMesh::kNone) nextSharp.insert({edgeKey(a, m), edgeKey(m, b)});
            } else {
                const glm::vec3 c = in.positions[h.halfEdge(HalfEdgeMesh::next(he)).to];
                const glm::vec3 d = in.positions[h.halfEdge(HalfEdgeMesh::next(t)).to];
                out.positions.push_back(0.375f * (pa + pb) + 0.125f * (c + d));
            }
            it->second = m;
        }
        return it->second;
    };
    splitInFour(in, out, odd);
    sharp = std::move(nextSharp);
    return out;
}

}  // namespace

TriMesh loopSubdivide(const TriMesh& in, int levels, double creaseAngleDegrees) {
    std::unordered_set<std::uint64_t> sharp;
    if (creaseAngleDegrees > 0.0 && creaseAngleDegrees < 180.0) {
        const double cosLimit = std::cos(creaseAngleDegrees * M_PI / 180.0);
        std::unordered_map<std::uint64_t, glm::dvec3> firstNormal;
        for (const glm::uvec3& t : in.triangles) {
            const glm::dvec3 a(in.positions[t.x]), b(in.positions[t.y]), c(in.positions[t.z]);
            const glm::dvec3 cr = glm::cross(b - a, c - a);
            const double len = glm::length(cr);
            const glm::dvec3 n = len > 0 ? cr / len : glm::dvec3(0.0);
            for (int e = 0; e < 3; ++e) {
                const std::uint64_t k = edgeKey(t[e], t[(e + 1) % 3]);
                auto [it, added] = firstNormal.try_emplace(k, n);
                if (!added && glm::dot(it->second, n) < cosLimit) sharp.insert(k);
            }
        }
    }
    TriMesh m = in;
    for (int i = 0; i < levels; ++i) m = loopStep(m, sharp);
    return m;
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

std::vector<glm::vec2> chaikin(std::vector<glm::vec2> p, int levels, bool closed) {
    for (int l = 0; l < levels && p.size() >= 2; ++l) {
        std::vector<glm::vec2> q;
        q.reserve(2 * p.size());
        const std::size_t n = p.size(), edges = closed ? n : n - 1;
        if (!closed) q.push_back(p.front());
        for (std::size_t i = 0; i < edges; ++i) {
            const glm::vec2 a = p[i], b = p[(i + 1) % n];
            q.push_back(0.75f * a + 0.25f * b);
            q.push_back(0.25f * a + 0.75f * b);
        }
        if (!closed) q.push_back(p.back());
        p = std::move(q);
    }
    return p;
}

std::vector<glm::vec2> fourPoint(std::vector<glm::vec2> p, int levels, bool closed) {
    for (int l = 0; l < levels && p.size() >= 3; ++l) {
        const std::size_t n = p.size(), edges = closed ? n : n - 1;
        auto at = [&](std::ptrdiff_t i) {
            if (closed) return p[std::size_t((i % std::ptrdiff_t(n) + std::ptrdiff_t(n)) % std::ptrdiff_t(n))];
            if (i < 0) return 2.0f * p.front() - p[std::size_t(-i)];  // mirrored end
            if (i >= std::ptrdiff_t(n)) return 2.0f * p.back() - p[2 * (n - 1) - std::size_t(i)];
            return p[std::size_t(i)];
        };
        std::vector<glm::vec2> q;
        q.reserve(2 * n);
        for (std::size_t e = 0; e < edges; ++e) {
            const auto i = std::ptrdiff_t(e);
            q.push_back(p[e]);
            q.push_back(9.0f / 16.0f * (at(i) + at(i + 1)) - 1.0f / 16.0f * (at(i - 1) + at(i + 2)));
        }
        if (!closed) q.push_back(p.back());
        p = std::move(q);
    }
    return p;
}

}  // namespace isoforge::mesh
