#include "mesh/halfedge.h"

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

bool HalfEdgeMesh::flip(std::uint32_t h) {
    const std::uint32_t t = he_[h].twin;
    if (t == kNone) return false;
    const std::uint32_t a = from(h), b = he_[h].to, c = he_[next(h)].to, d = he_[next(t)].to;
    if (c == d) return false;
    for (std::uint32_t w : oneRing(c))
        if (w == d) return false;  // the new edge exists already
    faces_[he_[h].face] = {a, d, c};
    faces_[he_[t].face] = {d, b, c};
    build();
    return true;
}

std::uint32_t HalfEdgeMesh::split(std::uint32_t h) {
    const std::uint32_t t = he_[h].twin;
    const std::uint32_t a = from(h), b = he_[h].to, c = he_[next(h)].to;
    const auto m = static_cast<std::uint32_t>(positions_.size());
    positions_.push_back(0.5f * (positions_[a] + positions_[b]));
    const std::uint32_t f = he_[h].face;
    faces_[f] = {a, m, c};
    faces_.push_back({m, b, c});
    if (t != kNone) {
        const std::uint32_t d = he_[next(t)].to, g = he_[t].face;
        faces_[g] = {b, m, d};
        faces_.push_back({m, a, d});
    }
    build();
    return m;
}

TriMesh HalfEdgeMesh::toTriMesh() const {
    TriMesh m;
    m.positions = positions_;
    m.triangles = faces_;
    return m;
}

}  // namespace isoforge::mesh
