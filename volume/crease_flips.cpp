#include "volume/crease_flips.h"

#include "mesh/self_intersections.h"
#include "volume/hermite.h"

#include <algorithm>
#include <array>
#include <unordered_map>
#include <unordered_set>

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <glm/geometric.hpp>

namespace isoforge::volume {

using namespace hermite;

// Kobbelt et al.'s edge flip across cells; see crease_flips.h.
std::size_t flipCreases(const std::vector<glm::vec3>& P, std::vector<glm::uvec3>& tris,
                        const std::vector<std::int64_t>& cellOf, unsigned firstApex, std::size_t cellCount,
                        const IndexField& field, const std::vector<char>& reachingApex) {
    auto isApex = [&](unsigned v) { return v >= firstApex; };
    // An apex beyond its cell has its fan in its reach's box, not in the cell: never flipped.
    auto reaches = [&](unsigned v) { return isApex(v) && reachingApex[v - firstApex]; };
    auto edgeKey = [](unsigned a, unsigned b) { return (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b); };
    // Only fan triangles (apex first) matter: a candidate's two triangles are fans, every edge a flip
    // adds or changes has an apex at one end, and a feature cell holds only its fan. Their edges as
    // (key, triangle), sorted: an edge's triangles are neighbours, in mesh order.
    std::vector<std::size_t> fans;
    for (std::size_t t = 0; t < tris.size(); ++t)
        if (isApex(tris[t].x)) fans.push_back(t);
    std::vector<std::pair<std::uint64_t, std::size_t>> edgeTris(3 * fans.size());
    tbb::parallel_for(std::size_t{0}, fans.size(), [&](std::size_t i) {
        const glm::uvec3& t = tris[fans[i]];
        for (int k = 0; k < 3; ++k) edgeTris[3 * i + std::size_t(k)] = {edgeKey(t[k], t[(k + 1) % 3]), fans[i]};
    });
    tbb::parallel_sort(edgeTris.begin(), edgeTris.end());
    // Each cell's fan triangles (cellFans from cellStart[c] to cellStart[c + 1]), in mesh order.
    std::vector<std::size_t> cellStart(cellCount + 1, 0), cellFans;
    for (std::size_t t : fans)
        if (cellOf[t] >= 0) ++cellStart[std::size_t(cellOf[t]) + 1];
    for (std::size_t c = 0; c < cellCount; ++c) cellStart[c + 1] += cellStart[c];
    cellFans.resize(cellStart.back());
    {
        std::vector<std::size_t> next(cellStart.begin(), cellStart.end() - 1);
        for (std::size_t t : fans)
            if (cellOf[t] >= 0) cellFans[next[std::size_t(cellOf[t])]++] = t;
    }
    // Candidates, in key order: an edge between two fan triangles (the first and the last of its
    // triangles) whose apexes are the feature vertices of two cells.
    struct Candidate {
        std::size_t t1, t2;
    };
    std::vector<Candidate> candidates;
    for (std::size_t i = 0; i < edgeTris.size();) {
        std::size_t j = i + 1;
        while (j < edgeTris.size() && edgeTris[j].first == edgeTris[i].first) ++j;
        const std::uint64_t key = edgeTris[i].first;
        const std::size_t t1 = edgeTris[i].second, t2 = edgeTris[j - 1].second;
        if (j - i >= 2 && tris[t1].x != tris[t2].x && !reaches(tris[t1].x) && !reaches(tris[t2].x) &&
            !isApex(unsigned(key >> 32)) && !isApex(unsigned(key & 0xffffffffu)))
            candidates.push_back({t1, t2});
        i = j;
    }
    auto unit = [](const glm::dvec3& v) {
        const double l = glm::length(v);
        return l > 0 ? v / l : glm::dvec3(0.0);
    };
    auto normalOf = [&](const glm::uvec3& t) {
        return glm::cross(glm::dvec3(P[t.y]) - glm::dvec3(P[t.x]), glm::dvec3(P[t.z]) - glm::dvec3(P[t.x]));
    };
    // Each candidate's turn: its pair t1 = (c1, a, b), t2 = (c2, b, a) and the new pair n1 = (c1, a, c2),
    // n2 = (c1, c2, b), kept if both new triangles face the old pair's way, with their fits (1 - cos of the
    // angle between a triangle's normal and the field's at its centre, summed over the pair), in batches of
    // neighbouring candidates. A candidate's two triangles are still its own when its turn comes (a flip
    // changes only its own pair), so all of this can be found before any flip.
    struct Turn {
        bool ok = false;
        std::size_t i1 = 0, i2 = 0;
        std::array<glm::uvec3, 4> tri;  // t1, t2, n1, n2
        double before = 0, after = 0;
    };
    std::vector<Turn> turns(candidates.size());
    tbb::parallel_for(std::size_t{0}, batchCount(candidates.size()), [&](std::size_t batch) {
        const std::size_t begin = batch * kBatch, end = std::min(candidates.size(), begin + kBatch);
        std::vector<glm::vec3> pts;
        Bounds box;
        for (std::size_t c = begin; c < end; ++c) {
            Turn& u = turns[c];
            u.i1 = candidates[c].t1;
            u.i2 = candidates[c].t2;
            const glm::uvec3 t1 = tris[u.i1], t2 = tris[u.i2];
            if (!(t2.y == t1.z && t2.z == t1.y)) continue;
            u.tri = {t1, t2, glm::uvec3(t1.x, t1.y, t2.x), glm::uvec3(t1.x, t2.x, t1.z)};
            const glm::dvec3 old = unit(normalOf(t1) + normalOf(t2));
            if (!(glm::dot(unit(normalOf(u.tri[2])), old) > 0.2 && glm::dot(unit(normalOf(u.tri[3])), old) > 0.2))
                continue;
            u.ok = true;
            for (const glm::uvec3& t : u.tri) {
                const glm::vec3 centre = (P[t.x] + P[t.y] + P[t.z]) / 3.f;
                box.add(centre);
                pts.push_back(centre);
            }
        }
        if (pts.empty()) return;
        std::vector<glm::vec3> normals;
        gradientsAt(box.of(field), pts, normals);
        const glm::vec3* g = normals.data();
        for (std::size_t c = begin; c < end; ++c) {
            Turn& u = turns[c];
            if (!u.ok) continue;
            double misfit[4];
            for (int k = 0; k < 4; ++k, ++g)
                misfit[k] = 1.0 - glm::dot(unit(normalOf(u.tri[std::size_t(k)])), unit(glm::dvec3(*g)));
            u.before = misfit[0] + misfit[1];
            u.after = misfit[2] + misfit[3];
        }
    });
    std::vector<char> flipped(tris.size(), 0);
    std::size_t flips = 0;
    // Apex-to-apex edges, which only flips make (a fan's edges join its apex to its loop, or two loop
    // vertices), and the flipped triangles that reach into a cell beside its own fan.
    std::unordered_set<std::uint64_t> apexEdges;
    std::unordered_map<std::size_t, std::vector<std::size_t>> reaching;
    for (std::size_t c = 0; c < candidates.size(); ++c) {
        const Turn& u = turns[c];
        const std::size_t i1 = u.i1, i2 = u.i2;
        if (!u.ok || flipped[i1] || flipped[i2] || !(u.after < u.before - 1e-4)) continue;
        const glm::uvec3 &n1 = u.tri[2], &n2 = u.tri[3];
        const unsigned c1 = n1.x, c2 = n1.z;
        if (apexEdges.count(edgeKey(c1, c2))) continue;  // the mesh would stop being manifold
        // Exact tests against everything in the two cells (and earlier flips into them).
        auto against = [&](const glm::uvec3& nt) {
            const std::array<glm::vec3, 3> pn{P[nt.x], P[nt.y], P[nt.z]};
            auto crosses = [&](std::size_t o) {
                if (o == i1 || o == i2) return false;
                const glm::uvec3& ot = tris[o];
                return mesh::trianglesIntersect(pn, {nt.x, nt.y, nt.z}, {P[ot.x], P[ot.y], P[ot.z]},
                                                {ot.x, ot.y, ot.z});
            };
            for (std::int64_t cell : {cellOf[i1], cellOf[i2]}) {
                if (cell < 0) return true;
                const std::size_t ce = std::size_t(cell);
                for (std::size_t k = cellStart[ce]; k < cellStart[ce + 1]; ++k)
                    if (crosses(cellFans[k])) return true;
                const auto more = reaching.find(ce);
                if (more != reaching.end())
                    for (std::size_t o : more->second)
                        if (crosses(o)) return true;
            }
            return false;
        };
        const bool clash = against(n1) || against(n2) ||
                           mesh::trianglesIntersect({P[n1.x], P[n1.y], P[n1.z]}, {n1.x, n1.y, n1.z},
                                                    {P[n2.x], P[n2.y], P[n2.z]}, {n2.x, n2.y, n2.z});
        if (clash) continue;
        tris[i1] = n1;
        tris[i2] = n2;
        flipped[i1] = flipped[i2] = 1;
        ++flips;
        apexEdges.insert(edgeKey(c1, c2));
        // Each new triangle now reaches into both cells.
        for (std::int64_t cell : {cellOf[i1], cellOf[i2]}) {
            const std::size_t ce = std::size_t(cell);
            const auto own = cellFans.begin() + std::ptrdiff_t(cellStart[ce]),
                       ownEnd = cellFans.begin() + std::ptrdiff_t(cellStart[ce + 1]);
            for (std::size_t t : {i1, i2}) {
                if (std::find(own, ownEnd, t) != ownEnd) continue;
                std::vector<std::size_t>& v = reaching[ce];
                if (std::find(v.begin(), v.end(), t) == v.end()) v.push_back(t);
            }
        }
    }
    return flips;
}

}  // namespace isoforge::volume
