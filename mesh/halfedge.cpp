#include "mesh/halfedge.h"

#include <initializer_list>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace isoforge::mesh {

namespace {
std::uint64_t directed(std::uint32_t a, std::uint32_t b) {
    return (std::uint64_t(a) << 32) | b;
}
}  // namespace

HalfEdgeMesh::HalfEdgeMesh(const TriMesh& m) : positions_(m.positions), faces_(m.triangles) {
    build();
}

void HalfEdgeMesh::build() {
    he_.assign(faces_.size() * 3, HalfEdge{kNone, kNone, kNone});
    out_.assign(positions_.size(), kNone);
    std::unordered_map<std::uint64_t, std::uint32_t> byEnds;
    byEnds.reserve(he_.size());
    std::size_t repeated = 0;
    std::string example;
    for (std::uint32_t f = 0; f < faces_.size(); ++f) {
        const glm::uvec3& t = faces_[f];
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t a = t[k], b = t[(k + 1) % 3], h = 3 * f + static_cast<std::uint32_t>(k);
            if (a >= positions_.size() || b >= positions_.size() || a == b)
                throw std::invalid_argument("half-edge mesh: triangle " + std::to_string(f) +
                                            " is degenerate or names a missing vertex");
            he_[h] = {b, f, kNone};
            if (!byEnds.emplace(directed(a, b), h).second && repeated++ == 0)
                example = "edge " + std::to_string(a) + "-" + std::to_string(b);
        }
    }
    if (repeated)
        throw std::invalid_argument("half-edge mesh: " + std::to_string(repeated) +
                                    " half-edges used twice in one direction (an edge of more than two triangles, or "
                                    "inconsistent orientation; first: " +
                                    example + "): repair the mesh first");
    for (std::uint32_t h = 0; h < he_.size(); ++h) {
        const std::uint32_t a = from(h), b = he_[h].to;
        if (auto it = byEnds.find(directed(b, a)); it != byEnds.end()) he_[h].twin = it->second;
        // Prefer the boundary half-edge as a vertex's outgoing one, so rotations start at a fan's end.
        if (out_[a] == kNone || he_[h].twin == kNone) out_[a] = h;
    }
    // Vertex-manifold: the rotation from outgoing(v) must visit every outgoing half-edge of v.
    std::vector<std::uint32_t> outCount(positions_.size(), 0);
    for (std::uint32_t h = 0; h < he_.size(); ++h) ++outCount[from(h)];
    std::size_t pinched = 0;
    std::uint32_t firstPinched = 0;
    for (std::uint32_t v = 0; v < positions_.size(); ++v)
        if (out_[v] != kNone && facesAround(v).size() != outCount[v] && pinched++ == 0) firstPinched = v;
    if (pinched)
        throw std::invalid_argument("half-edge mesh: " + std::to_string(pinched) +
                                    " vertices where several fans of triangles meet (first: vertex " +
                                    std::to_string(firstPinched) + "): not vertex-manifold");
}

std::vector<std::uint32_t> HalfEdgeMesh::facesAround(std::uint32_t v) const {
    std::vector<std::uint32_t> faces;
    const std::uint32_t start = out_[v];
    if (start == kNone) return faces;
    // Around v: from an outgoing half-edge h, the previous half-edge of its face comes into v; its twin
    // goes out of v in the next face.
    std::uint32_t h = start;
    do {
        faces.push_back(he_[h].face);
        const std::uint32_t t = he_[prev(h)].twin;
        if (t == kNone || faces.size() > he_.size()) break;
        h = t;
    } while (h != start);
    return faces;
}

std::vector<std::uint32_t> HalfEdgeMesh::oneRing(std::uint32_t v) const {
    std::vector<std::uint32_t> ring;
    const std::uint32_t start = out_[v];
    if (start == kNone) return ring;
    std::uint32_t h = start;
    for (;;) {
        ring.push_back(he_[h].to);
        const std::uint32_t t = he_[prev(h)].twin;
        if (t == kNone) {  // the other end of a boundary fan: the incoming edge's start closes the ring
            ring.push_back(from(prev(h)));
            break;
        }
        h = t;
        if (h == start || ring.size() > he_.size()) break;
    }
    return ring;
}

bool HalfEdgeMesh::isBoundaryVertex(std::uint32_t v) const {
    return out_[v] != kNone && he_[out_[v]].twin == kNone;
}

std::vector<std::vector<std::uint32_t>> HalfEdgeMesh::boundaryLoops() const {
    std::vector<std::vector<std::uint32_t>> loops;
    std::vector<bool> used(he_.size(), false);
    for (std::uint32_t h = 0; h < he_.size(); ++h) {
        if (he_[h].twin != kNone || used[h]) continue;
        std::vector<std::uint32_t> loop;
        std::uint32_t g = h;
        while (!used[g]) {
            used[g] = true;
            loop.push_back(from(g));
            g = out_[he_[g].to];  // the boundary half-edge leaving the end vertex
            if (g == kNone || he_[g].twin != kNone) break;
        }
        loops.push_back(std::move(loop));
    }
    return loops;
}

void HalfEdgeMesh::setFace(std::uint32_t f, const glm::uvec3& t) {
    faces_[f] = t;
    for (std::uint32_t k = 0; k < 3; ++k) he_[3 * f + k] = {t[(k + 1) % 3], f, kNone};
}

void HalfEdgeMesh::link(std::uint32_t h, std::uint32_t t) {
    he_[h].twin = t;
    if (t != kNone) he_[t].twin = h;
}

void HalfEdgeMesh::refreshOutgoing(std::initializer_list<std::uint32_t> vertices,
                                   std::initializer_list<std::uint32_t> faces) {
    auto inFaces = [&](std::uint32_t h) {
        for (std::uint32_t f : faces)
            if (h / 3 == f) return true;
        return false;
    };
    for (std::uint32_t v : vertices) {
        if (out_[v] != kNone && !inFaces(out_[v])) continue;  // untouched: still outgoing, still preferred
        std::uint32_t best = kNone;
        for (std::uint32_t f : faces)
            for (std::uint32_t k = 0; k < 3; ++k) {
                const std::uint32_t h = 3 * f + k;
                if (from(h) != v) continue;
                if (best == kNone || (he_[h].twin == kNone && he_[best].twin != kNone)) best = h;
            }
        out_[v] = best;
    }
}

bool HalfEdgeMesh::flip(std::uint32_t h) {
    const std::uint32_t t = he_[h].twin;
    if (t == kNone) return false;
    const std::uint32_t a = from(h), b = he_[h].to, c = he_[next(h)].to, d = he_[next(t)].to;
    if (c == d) return false;
    for (std::uint32_t w : oneRing(c))
        if (w == d) return false;  // the new edge exists already
    const std::uint32_t f = he_[h].face, g = he_[t].face;
    // The four outer edges keep their twins across the change.
    const std::uint32_t bc = he_[next(h)].twin, ca = he_[prev(h)].twin, ad = he_[next(t)].twin, db = he_[prev(t)].twin;
    setFace(f, {a, d, c});  // a->d, d->c, c->a
    setFace(g, {d, b, c});  // d->b, b->c, c->d
    link(3 * f, ad);
    link(3 * f + 1, 3 * g + 2);
    link(3 * f + 2, ca);
    link(3 * g, db);
    link(3 * g + 1, bc);
    refreshOutgoing({a, b, c, d}, {f, g});
    return true;
}

std::uint32_t HalfEdgeMesh::split(std::uint32_t h) {
    const std::uint32_t t = he_[h].twin;
    const std::uint32_t a = from(h), b = he_[h].to, c = he_[next(h)].to;
    const auto m = static_cast<std::uint32_t>(positions_.size());
    positions_.push_back(0.5f * (positions_[a] + positions_[b]));
    out_.push_back(kNone);
    const std::uint32_t f = he_[h].face, bc = he_[next(h)].twin, ca = he_[prev(h)].twin;
    const auto F = static_cast<std::uint32_t>(faces_.size());
    faces_.emplace_back();
    he_.resize(he_.size() + 3);
    setFace(f, {a, m, c});  // a->m, m->c, c->a
    setFace(F, {m, b, c});  // m->b, b->c, c->m
    link(3 * f + 1, 3 * F + 2);
    link(3 * f + 2, ca);
    link(3 * F + 1, bc);
    if (t == kNone) {
        refreshOutgoing({a, b, c, m}, {f, F});
        return m;
    }
    const std::uint32_t d = he_[next(t)].to, g = he_[t].face, ad = he_[next(t)].twin, db = he_[prev(t)].twin;
    const std::uint32_t G = F + 1;
    faces_.emplace_back();
    he_.resize(he_.size() + 3);
    setFace(g, {b, m, d});  // b->m, m->d, d->b
    setFace(G, {m, a, d});  // m->a, a->d, d->m
    link(3 * f, 3 * G);
    link(3 * F, 3 * g);
    link(3 * g + 1, 3 * G + 2);
    link(3 * g + 2, db);
    link(3 * G + 1, ad);
    refreshOutgoing({a, b, c, d, m}, {f, F, g, G});
    return m;
}

TriMesh HalfEdgeMesh::toTriMesh() const {
    TriMesh m;
    m.positions = positions_;
    m.triangles = faces_;
    return m;
}

}  // namespace isoforge::mesh
