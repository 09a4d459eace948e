#include "mesh/repair.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <sstream>
#include <unordered_map>

#include <glm/geometric.hpp>

namespace isoforge::mesh {

namespace {

std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b) {
    return (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
}
/// +1 if triangle t uses the edge as a -> b, -1 as b -> a.
int direction(const glm::uvec3& t, std::uint32_t a, std::uint32_t b) {
    for (int k = 0; k < 3; ++k) {
        if (t[k] == a && t[(k + 1) % 3] == b) return 1;
        if (t[k] == b && t[(k + 1) % 3] == a) return -1;
    }
    return 0;
}
double signedVolume(const TriMesh& m, const std::vector<std::uint32_t>& faces) {
    double v = 0;
    for (std::uint32_t f : faces) {
        const auto& t = m.triangles[f];
        v += glm::dot(glm::dvec3(m.positions[t.x]),
                      glm::cross(glm::dvec3(m.positions[t.y]), glm::dvec3(m.positions[t.z])));
    }
    return v / 6.0;
}
/// Whether point p is inside the closed component (generalized winding number > 1/2).
bool contains(const TriMesh& m, const std::vector<std::uint32_t>& faces, const glm::dvec3& p) {
    double w = 0;
    for (std::uint32_t f : faces) {
        const auto& t = m.triangles[f];
        const glm::dvec3 a = glm::dvec3(m.positions[t.x]) - p, b = glm::dvec3(m.positions[t.y]) - p,
                         c = glm::dvec3(m.positions[t.z]) - p;
        const double la = glm::length(a), lb = glm::length(b), lc = glm::length(c);
        w += 2.0 * std::atan2(glm::dot(a, glm::cross(b, c)),
                              la * lb * lc + glm::dot(a, b) * lc + glm::dot(b, c) * la + glm::dot(c, a) * lb);
    }
    return std::abs(w) > 2.0 * M_PI;
}

}  // namespace

std::string RepairReport::toString() const {
    std::ostringstream s;
    s << "degenerate removed   " << degenerateRemoved << "\n"
      << "duplicates removed   " << duplicatesRemoved << "\n"
      << "triangles flipped    " << trianglesFlipped << "\n"
      << "components inverted  " << componentsInverted << "\n";
    if (nonOrientableComponents) s << "NOT FIXED: " << nonOrientableComponents << " non-orientable components\n";
    if (nonManifoldEdges)
        s << "NOT FIXED: " << nonManifoldEdges << " non-manifold edges (orientation not carried across)\n";
    if (openComponents) s << "open components      " << openComponents << " (consistent, not tested for outward)\n";
    return s.str();
}

RepairReport repair(TriMesh& m) {
    RepairReport r;
    // 1. Degenerate and duplicate triangles.
    std::set<std::array<std::uint32_t, 3>> seen;
    std::vector<glm::uvec3> kept;
    kept.reserve(m.triangles.size());
    for (const auto& t : m.triangles) {
        if (t.x >= m.positions.size() || t.y >= m.positions.size() || t.z >= m.positions.size() || t.x == t.y ||
            t.y == t.z || t.z == t.x ||
            glm::length(glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x])) == 0.f) {
            ++r.degenerateRemoved;
            continue;
        }
        std::array<std::uint32_t, 3> key{t.x, t.y, t.z};
        std::sort(key.begin(), key.end());
        if (!seen.insert(key).second) {
            ++r.duplicatesRemoved;
            continue;
        }
        kept.push_back(t);
    }
    m.triangles = std::move(kept);

    // 2. Consistent orientation per component, across edges of exactly two triangles.
    std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> edges;
    for (std::uint32_t f = 0; f < m.triangles.size(); ++f)
        for (int k = 0; k < 3; ++k) edges[edgeKey(m.triangles[f][k], m.triangles[f][(k + 1) % 3])].push_back(f);
    for (const auto& [key, fs] : edges) r.nonManifoldEdges += fs.size() > 2;
    std::vector<int> component(m.triangles.size(), -1);
    std::vector<std::vector<std::uint32_t>> comps;
    std::vector<bool> closed;
    for (std::uint32_t seed = 0; seed < m.triangles.size(); ++seed) {
        if (component[seed] >= 0) continue;
        const int c = static_cast<int>(comps.size());
        comps.emplace_back(std::vector<std::uint32_t>{seed});
        closed.push_back(true);
        component[seed] = c;
        bool orientable = true;
        for (std::size_t i = 0; i < comps[c].size(); ++i) {
            const std::uint32_t f = comps[c][i];
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t a = m.triangles[f][k], b = m.triangles[f][(k + 1) % 3];
                const auto& fs = edges[edgeKey(a, b)];
                if (fs.size() == 1) closed.back() = false;
                if (fs.size() != 2) {
                    if (fs.size() > 2) closed.back() = false;
                    continue;
                }
                const std::uint32_t g = fs[0] == f ? fs[1] : fs[0];
                const bool agree = direction(m.triangles[g], a, b) == -1;  // neighbours run a shared edge oppositely
                if (component[g] >= 0) {
                    orientable = orientable && agree;
                    continue;
                }
                if (!agree) {
                    std::swap(m.triangles[g].y, m.triangles[g].z);
                    ++r.trianglesFlipped;
                }
                component[g] = c;
                comps[c].push_back(g);
            }
        }
        if (!orientable) ++r.nonOrientableComponents;
    }

    // 3. Outward: closed components by nesting depth (cavities inward), open ones left as they are.
    for (std::size_t c = 0; c < comps.size(); ++c) {
        if (!closed[c]) {
            ++r.openComponents;
            continue;
        }
        const glm::dvec3 p(m.positions[m.triangles[comps[c][0]].x]);
        int depth = 0;
        for (std::size_t d = 0; d < comps.size(); ++d)
            if (d != c && closed[d] && contains(m, comps[d], p)) ++depth;
        const double v = signedVolume(m, comps[c]);
        const bool wantPositive = depth % 2 == 0;
        if ((v > 0) != wantPositive && v != 0) {
            for (std::uint32_t f : comps[c]) std::swap(m.triangles[f].y, m.triangles[f].z);
            ++r.componentsInverted;
        }
    }
    return r;
}

}  // namespace isoforge::mesh
