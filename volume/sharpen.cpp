#include "volume/sharpen.h"

#include "mesh/self_intersections.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <map>
#include <memory>
#include <unordered_map>
#include <vector>

#include <openvdb/tools/Interpolation.h>
#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

namespace isoforge::volume {

namespace {

constexpr float kMargin = 1e-3f;  // crossings and apexes stay this far (voxels) from cell corners and faces

/// The grid edge a marching cubes vertex lies on: its lower corner and axis.
struct Edge {
    glm::ivec3 corner;
    int axis = -1;
};

Edge edgeOf(const glm::vec3& p) {
    Edge e;
    float best = -1.f;
    for (int k = 0; k < 3; ++k) {
        const float f = p[k] - std::floor(p[k]);
        const float off = std::min(f, 1.f - f);  // distance to the nearest integer
        if (off > best) {
            best = off;
            e.axis = k;
        }
    }
    for (int k = 0; k < 3; ++k) e.corner[k] = k == e.axis ? int(std::floor(p[k])) : int(std::lround(p[k]));
    return e;
}

glm::vec3 gradientAt(const IndexField& value, const glm::vec3& p) {
    constexpr float h = 1e-3f;
    glm::vec3 g;
    for (int k = 0; k < 3; ++k) {
        glm::vec3 a = p, b = p;
        a[k] -= h;
        b[k] += h;
        g[k] = (value(b) - value(a)) / (2.f * h);
    }
    return g;
}

/// Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi rotations.
void jacobi(glm::dmat3 a, glm::dvec3& eigenvalues, glm::dmat3& vectors) {
    vectors = glm::dmat3(1.0);
    for (int sweep = 0; sweep < 32; ++sweep) {
        const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        if (off < 1e-30) break;
        for (int p = 0; p < 2; ++p)
            for (int q = p + 1; q < 3; ++q) {
                if (std::abs(a[p][q]) < 1e-300) continue;
                const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
                const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
                glm::dmat3 r(1.0);
                r[p][p] = c;
                r[q][q] = c;
                r[q][p] = s;  // column q, row p
                r[p][q] = -s;
                a = glm::transpose(r) * a * r;
                vectors = vectors * r;
            }
    }
    eigenvalues = glm::dvec3(a[0][0], a[1][1], a[2][2]);
}

struct Patch {
    std::vector<std::size_t> triangles;  // in mesh order
    std::vector<unsigned> loop;          // boundary vertices in the patch's orientation
};

/// Follows creases across cells (Kobbelt et al.'s edge flip): two fan triangles (c1, a, b) and
/// (c2, b, a) of face-neighbouring cells, with feature vertices c1 and c2, become (c1, a, c2) and
/// (c1, c2, b) when the field's normals at their centres agree better with the new pair. Both new
/// triangles lie in the box of the two cells and meet its boundary only at a or b, so only the
/// triangles of those two cells (and earlier flips into them) can cross them: each flip is tested
/// against those with exact predicates and skipped if any pair intersects, or if c1-c2 is already an
/// edge (the mesh would stop being manifold). Edges in a fixed order, each triangle flipped once.
std::size_t flipCreases(const std::vector<glm::vec3>& P, std::vector<glm::uvec3>& tris,
                        const std::vector<std::int64_t>& cellOf, unsigned firstApex, std::size_t cellCount,
                        const IndexField& value) {
    auto isApex = [&](unsigned v) { return v >= firstApex; };
    auto edgeKey = [](unsigned a, unsigned b) { return (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b); };
    std::unordered_map<std::uint64_t, std::array<std::int64_t, 2>> edgeTris;
    edgeTris.reserve(tris.size() * 2);
    std::vector<std::vector<std::size_t>> inCell(cellCount);
    for (std::size_t t = 0; t < tris.size(); ++t) {
        for (int k = 0; k < 3; ++k) {
            auto [it, added] = edgeTris.try_emplace(edgeKey(tris[t][k], tris[t][(k + 1) % 3]),
                                                    std::array<std::int64_t, 2>{std::int64_t(t), -1});
            if (!added) it->second[1] = std::int64_t(t);
        }
        if (cellOf[t] >= 0) inCell[std::size_t(cellOf[t])].push_back(t);
    }
    // Candidates: an edge between two fan triangles whose apexes are feature vertices of two cells.
    std::vector<std::uint64_t> candidates;
    for (const auto& [key, ts] : edgeTris) {
        if (ts[1] < 0) continue;
        const glm::uvec3 &t1 = tris[std::size_t(ts[0])], &t2 = tris[std::size_t(ts[1])];
        if (isApex(t1.x) && isApex(t2.x) && t1.x != t2.x && !isApex(unsigned(key >> 32)) &&
            !isApex(unsigned(key & 0xffffffffu)))
            candidates.push_back(key);
    }
    std::sort(candidates.begin(), candidates.end());
    auto unit = [](const glm::dvec3& v) {
        const double l = glm::length(v);
        return l > 0 ? v / l : glm::dvec3(0.0);
    };
    auto normalOf = [&](const glm::uvec3& t) {
        return glm::cross(glm::dvec3(P[t.y]) - glm::dvec3(P[t.x]), glm::dvec3(P[t.z]) - glm::dvec3(P[t.x]));
    };
    auto misfit = [&](const glm::uvec3& t) {  // 1 - cos of the angle to the field's normal at the centre
        const glm::vec3 centre = (P[t.x] + P[t.y] + P[t.z]) / 3.f;
        return 1.0 - glm::dot(unit(normalOf(t)), unit(glm::dvec3(gradientAt(value, centre))));
    };
    std::vector<char> flipped(tris.size(), 0);
    std::size_t flips = 0;
    for (const std::uint64_t key : candidates) {
        const auto ts = edgeTris.at(key);
        if (ts[1] < 0) continue;
        const std::size_t i1 = std::size_t(ts[0]), i2 = std::size_t(ts[1]);
        if (flipped[i1] || flipped[i2]) continue;
        // t1 = (c1, a, b) runs a -> b; t2 = (c2, b, a).
        glm::uvec3 t1 = tris[i1], t2 = tris[i2];
        if (!isApex(t1.x) || !isApex(t2.x)) continue;
        const unsigned c1 = t1.x, a = t1.y, b = t1.z, c2 = t2.x;
        if (!(t2.y == b && t2.z == a)) continue;
        if (edgeTris.count(edgeKey(c1, c2))) continue;
        const glm::uvec3 n1(c1, a, c2), n2(c1, c2, b);
        const glm::dvec3 before = unit(normalOf(t1) + normalOf(t2));
        if (!(glm::dot(unit(normalOf(n1)), before) > 0.2 && glm::dot(unit(normalOf(n2)), before) > 0.2)) continue;
        if (!(misfit(n1) + misfit(n2) < misfit(t1) + misfit(t2) - 1e-4)) continue;
        // Exact tests against everything in the two cells (and earlier flips into them).
        bool clash = false;
        auto against = [&](const glm::uvec3& nt) {
            const std::array<glm::vec3, 3> pn{P[nt.x], P[nt.y], P[nt.z]};
            for (std::int64_t cell : {cellOf[i1], cellOf[i2]}) {
                if (cell < 0) return true;
                for (std::size_t o : inCell[std::size_t(cell)]) {
                    if (o == i1 || o == i2) continue;
                    const glm::uvec3& ot = tris[o];
                    if (mesh::trianglesIntersect(pn, {nt.x, nt.y, nt.z}, {P[ot.x], P[ot.y], P[ot.z]},
                                                 {ot.x, ot.y, ot.z}))
                        return true;
                }
            }
            return false;
        };
        clash = against(n1) || against(n2) ||
                mesh::trianglesIntersect({P[n1.x], P[n1.y], P[n1.z]}, {n1.x, n1.y, n1.z}, {P[n2.x], P[n2.y], P[n2.z]},
                                         {n2.x, n2.y, n2.z});
        if (clash) continue;
        tris[i1] = n1;
        tris[i2] = n2;
        flipped[i1] = flipped[i2] = 1;
        ++flips;
        // Edges: a-b is gone, c1-c2 is new; c1-a... keep their triangles up to date.
        edgeTris.erase(key);
        edgeTris[edgeKey(c1, c2)] = {std::int64_t(i1), std::int64_t(i2)};
        auto swapIn = [&](unsigned u, unsigned w, std::size_t from, std::size_t to) {
            auto& e = edgeTris[edgeKey(u, w)];
            for (auto& x : e)
                if (x == std::int64_t(from)) x = std::int64_t(to);
        };
        // n1 = (c1, a, c2) holds c1-a (was t1's) and a-c2 (was t2's); n2 = (c1, c2, b) holds c2-b (t2's), b-c1 (t1's).
        swapIn(a, c2, i2, i1);
        swapIn(b, c1, i1, i2);
        // Each new triangle now reaches into both cells.
        for (std::int64_t cell : {cellOf[i1], cellOf[i2]}) {
            auto& v = inCell[std::size_t(cell)];
            for (std::size_t t : {i1, i2})
                if (std::find(v.begin(), v.end(), t) == v.end()) v.push_back(t);
        }
    }
    return flips;
}

}  // namespace

void sharpen(mesh::TriMesh& mesh, const IndexField& value, SharpenStats* statsOut) {
    SharpenStats stats;
    auto& P = mesh.positions;
    const std::size_t nv = P.size();

    // 1. Exact crossings: each vertex moved onto the field's zero along its edge.
    std::vector<Edge> edges(nv);
    std::vector<char> moved(nv, 0);
    tbb::parallel_for(std::size_t{0}, nv, [&](std::size_t i) {
        const Edge e = edgeOf(P[i]);
        edges[i] = e;
        glm::vec3 a(e.corner), b(e.corner);
        b[e.axis] += 1.f;
        float fa = value(a), fb = value(b);
        if (!(fa * fb < 0.f)) return;  // the field does not cross here (the grid's sign differs): keep
        float ta = 0.f, tb = 1.f;
        int side = 0;
        float t = 0.5f;
        for (int it = 0; it < 24; ++it) {  // regula falsi, Illinois variant
            t = (ta * fb - tb * fa) / (fb - fa);
            if (!(t > ta && t < tb)) t = 0.5f * (ta + tb);
            glm::vec3 q = a;
            q[e.axis] += t;
            const float ft = value(q);
            if (ft == 0.f || tb - ta < 1e-6f) break;
            if ((ft < 0.f) == (fa < 0.f)) {
                ta = t;
                fa = ft;
                if (side == -1) fb *= 0.5f;
                side = -1;
            } else {
                tb = t;
                fb = ft;
                if (side == 1) fa *= 0.5f;
                side = 1;
            }
        }
        t = std::clamp(t, kMargin, 1.f - kMargin);
        P[i] = a;
        P[i][e.axis] += t;
        moved[i] = 1;
    });
    for (char m : moved) stats.refinedVertices += m;

    // 2. Each triangle's cell: the one cell around all three of its vertices' edges.
    auto cellsOf = [&](unsigned v, std::array<glm::ivec3, 4>& out) {
        const Edge& e = edges[v];
        const int u = (e.axis + 1) % 3, w = (e.axis + 2) % 3;
        for (int k = 0; k < 4; ++k) {
            glm::ivec3 c = e.corner;
            c[u] -= k & 1;
            c[w] -= (k >> 1) & 1;
            out[k] = c;
        }
    };
    auto key = [](const glm::ivec3& c) {
        return (std::uint64_t(std::uint32_t(c.x) & 0x1fffff) << 42) |
               (std::uint64_t(std::uint32_t(c.y) & 0x1fffff) << 21) | std::uint64_t(std::uint32_t(c.z) & 0x1fffff);
    };
    std::map<std::uint64_t, std::vector<std::size_t>> cells;  // ordered: a deterministic walk
    std::vector<std::uint64_t> ambiguous;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        std::array<std::array<glm::ivec3, 4>, 3> c;
        for (int k = 0; k < 3; ++k) cellsOf(mesh.triangles[t][k], c[k]);
        std::vector<glm::ivec3> common;
        for (const auto& a : c[0])
            if (std::find(c[1].begin(), c[1].end(), a) != c[1].end() &&
                std::find(c[2].begin(), c[2].end(), a) != c[2].end())
                common.push_back(a);
        if (common.empty()) continue;  // not a marching cubes triangle: left alone
        cells[key(common[0])].push_back(t);
        for (std::size_t k = 1; k < common.size(); ++k) ambiguous.push_back(key(common[k]));
        if (common.size() > 1) ambiguous.push_back(key(common[0]));
    }
    std::sort(ambiguous.begin(), ambiguous.end());

    // 3. Per cell: one patch, its boundary loop, the QEF's point, the checks.
    std::vector<std::pair<std::uint64_t, std::vector<std::size_t>>> list(cells.begin(), cells.end());
    std::vector<Patch> patches(list.size());
    std::vector<glm::vec3> apex(list.size());
    std::vector<char> result(list.size(), 0);  // 1 feature vertex, 2 flat, 3 kept, 4 several patches
    tbb::parallel_for(std::size_t{0}, list.size(), [&](std::size_t ci) {
        const auto& tris = list[ci].second;
        if (std::binary_search(ambiguous.begin(), ambiguous.end(), list[ci].first)) {
            result[ci] = 4;
            return;
        }
        // Directed edges; the patch is one disk when the undirected edges connect all triangles and the
        // unpaired directed edges form one cycle.
        std::map<std::pair<unsigned, unsigned>, int> directed;
        for (std::size_t t : tris)
            for (int k = 0; k < 3; ++k) ++directed[{mesh.triangles[t][k], mesh.triangles[t][(k + 1) % 3]}];
        std::map<unsigned, unsigned> next;
        bool ok = true;
        for (const auto& [e, n] : directed) {
            if (n != 1) ok = false;
            if (directed.count({e.second, e.first})) continue;
            if (next.count(e.first)) ok = false;
            next[e.first] = e.second;
        }
        if (!ok || next.size() < 3) {
            result[ci] = 4;
            return;
        }
        std::vector<unsigned> loop{next.begin()->first};
        while (loop.size() <= next.size()) {
            auto it = next.find(loop.back());
            if (it == next.end()) break;
            if (it->second == loop.front()) break;
            loop.push_back(it->second);
        }
        if (loop.size() != next.size()) {  // several loops: several patches
            result[ci] = 4;
            return;
        }
        // Euler: a disk of L boundary vertices and no interior ones has L - 2 triangles.
        if (tris.size() != loop.size() - 2) {
            result[ci] = 4;
            return;
        }
        // Hermite data: the crossings and the field's normals there.
        glm::dvec3 mass(0.0);
        for (unsigned v : loop) mass += glm::dvec3(P[v]);
        mass /= double(loop.size());
        glm::dmat3 A(0.0);
        glm::dvec3 b(0.0);
        for (unsigned v : loop) {
            glm::dvec3 n(gradientAt(value, P[v]));
            const double len = glm::length(n);
            if (!(len > 0) || !std::isfinite(len)) continue;
            n /= len;
            A += glm::outerProduct(n, n);
            b += n * glm::dot(n, glm::dvec3(P[v]) - mass);
        }
        glm::dvec3 lambda;
        glm::dmat3 V;
        int rank = 0;
        glm::dvec3 x(0.0);
        auto solve = [&] {
            jacobi(A, lambda, V);
            const double top = std::max({lambda.x, lambda.y, lambda.z});
            rank = 0;
            x = glm::dvec3(0.0);
            for (int k = 0; k < 3; ++k) {
                if (!(lambda[k] > 0.1 * top)) continue;
                ++rank;
                x += V[k] * (glm::dot(V[k], b) / lambda[k]);
            }
        };
        solve();
        if (rank < 2) {
            result[ci] = 2;
            return;
        }
        // A third face can cut a corner cell without crossing any of its edges: the crease point is
        // then off the surface. Probe there: the field's nearest surface point and normal join the
        // Hermite data (twice at most), which turns an edge point into the corner.
        for (int probe = 0; probe < 2; ++probe) {
            const glm::vec3 q(mass + x);
            const float f = value(q);
            const glm::vec3 gq = gradientAt(value, q);
            const double len = glm::length(glm::dvec3(gq));
            if (!(len > 0) || !std::isfinite(len)) break;
            const double dist = double(f) / len;  // in voxels
            if (!(std::abs(dist) > 0.02) || std::abs(dist) > 1.0) break;
            const glm::dvec3 n = glm::dvec3(gq) / len;
            const glm::dvec3 onSurface = glm::dvec3(q) - dist * n;
            A += glm::outerProduct(n, n);
            b += n * glm::dot(n, onSurface - mass);
            solve();
        }
        glm::dvec3 c = mass + x;
        // The cell's lower corner: the smallest corner of its crossings' edges.
        glm::dvec3 cellLo = glm::dvec3(1e30);
        for (unsigned v : loop) cellLo = glm::min(cellLo, glm::dvec3(edges[v].corner));
        const glm::dvec3 boxLo = cellLo + double(kMargin), boxHi = cellLo + (1.0 - double(kMargin));
        auto inBox = [&](const glm::dvec3& q) {
            return q.x >= boxLo.x && q.x <= boxHi.x && q.y >= boxLo.y && q.y <= boxHi.y && q.z >= boxLo.z &&
                   q.z <= boxHi.z;
        };
        if (!inBox(c)) {
            // The crease (rank 2: the line through c along the dropped eigenvector) may cross the cell
            // away from c: take its point in the cell nearest c, which has the same error. Otherwise the
            // nearest point of the cell (the cell's best feature point is on its boundary).
            bool onCrease = false;
            if (rank == 2) {
                int k0 = 0;
                for (int k = 1; k < 3; ++k)
                    if (lambda[k] < lambda[k0]) k0 = k;
                const glm::dvec3 d = V[k0];
                double s0 = -1e300, s1 = 1e300;
                for (int k = 0; k < 3; ++k) {
                    if (std::abs(d[k]) < 1e-12) {
                        if (c[k] < boxLo[k] || c[k] > boxHi[k]) s0 = 1e300;
                        continue;
                    }
                    double enter = (boxLo[k] - c[k]) / d[k], leave = (boxHi[k] - c[k]) / d[k];
                    if (enter > leave) std::swap(enter, leave);
                    s0 = std::max(s0, enter);
                    s1 = std::min(s1, leave);
                }
                if (s0 <= s1) {
                    c += d * std::clamp(0.0, s0, s1);
                    onCrease = inBox(c);
                }
            }
            if (!onCrease) c = glm::clamp(c, boxLo, boxHi);
        }
        // No fold: every fan triangle turns the patch's way in the plane across the patch's normal,
        // and the loop goes once around the apex there.
        glm::dvec3 N(0.0);
        for (std::size_t t : tris) {
            const glm::dvec3 p0(P[mesh.triangles[t][0]]), p1(P[mesh.triangles[t][1]]), p2(P[mesh.triangles[t][2]]);
            N += glm::cross(p1 - p0, p2 - p0);
        }
        if (!(glm::length(N) > 0)) {
            result[ci] = 3;
            return;
        }
        N = glm::normalize(N);
        const glm::dvec3 U = glm::normalize(std::abs(N.x) < 0.9 ? glm::cross(N, glm::dvec3(1, 0, 0))
                                                                : glm::cross(N, glm::dvec3(0, 1, 0)));
        const glm::dvec3 W = glm::cross(N, U);
        double turn = 0;
        for (std::size_t k = 0; k < loop.size(); ++k) {
            const glm::dvec3 a = glm::dvec3(P[loop[k]]) - c, d = glm::dvec3(P[loop[(k + 1) % loop.size()]]) - c;
            const glm::dvec2 a2(glm::dot(a, U), glm::dot(a, W)), d2(glm::dot(d, U), glm::dot(d, W));
            const double cr = a2.x * d2.y - a2.y * d2.x;
            if (!(cr > 1e-9 * (glm::dot(a2, a2) + glm::dot(d2, d2)))) {
                result[ci] = 3;
                return;
            }
            turn += std::atan2(cr, glm::dot(a2, d2));
        }
        if (!(std::abs(turn - 2.0 * M_PI) < 1e-3)) {
            result[ci] = 3;
            return;
        }
        patches[ci].triangles = tris;
        patches[ci].loop = std::move(loop);
        apex[ci] = glm::vec3(c);
        result[ci] = 1;
    });

    // 4. The mesh again, in its order: a sharpened patch's fan where its first triangle was.
    std::vector<std::int64_t> patchOfTriangle(mesh.triangles.size(), -1);
    for (std::size_t ci = 0; ci < list.size(); ++ci) {
        stats.patches += result[ci] != 4;
        stats.features += result[ci] == 1;
        stats.flat += result[ci] == 2;
        stats.kept += result[ci] == 3;
        stats.sharedCells += result[ci] == 4;
        if (result[ci] == 1)
            for (std::size_t t : patches[ci].triangles) patchOfTriangle[t] = std::int64_t(ci);
    }
    std::vector<glm::uvec3> out;
    std::vector<std::int64_t> cellOfOut;  // each output triangle's cell (list index), -1 if none
    std::vector<std::int64_t> cellOfTriangle(mesh.triangles.size(), -1);
    for (std::size_t ci = 0; ci < list.size(); ++ci)
        for (std::size_t t : list[ci].second) cellOfTriangle[t] = std::int64_t(ci);
    out.reserve(mesh.triangles.size() + 2 * stats.features);
    const auto firstApex = static_cast<unsigned>(P.size());
    std::vector<std::int64_t> apexCell;
    std::vector<char> emitted(list.size(), 0);
    const bool normals = mesh.normals.size() == nv, colors = mesh.colors.size() == nv;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const std::int64_t ci = patchOfTriangle[t];
        if (ci < 0) {
            out.push_back(mesh.triangles[t]);
            cellOfOut.push_back(cellOfTriangle[t]);
            continue;
        }
        if (emitted[ci]) continue;
        emitted[ci] = 1;
        const auto centre = static_cast<unsigned>(P.size());
        P.push_back(apex[ci]);
        apexCell.push_back(ci);
        const auto& loop = patches[ci].loop;
        if (normals) {
            glm::vec3 n(0.f);
            for (unsigned v : loop) n += mesh.normals[v];
            mesh.normals.push_back(glm::length(n) > 0 ? glm::normalize(n) : glm::vec3(0, 0, 1));
        }
        if (colors) mesh.colors.push_back(mesh.colors[loop[0]]);
        for (std::size_t k = 0; k < loop.size(); ++k) {
            out.emplace_back(centre, loop[k], loop[(k + 1) % loop.size()]);
            cellOfOut.push_back(ci);
        }
    }
    stats.flips = flipCreases(P, out, cellOfOut, firstApex, list.size(), value);
    mesh.triangles = std::move(out);
    if (statsOut) *statsOut = stats;
}

}  // namespace isoforge::volume

namespace isoforge::volume {

void sharpenWithGrid(mesh::TriMesh& mesh, const openvdb::FloatGrid& grid, float iso, bool insideBelow,
                     SharpenStats* stats) {
    const float sign = insideBelow ? 1.f : -1.f;
    // One sampler (and its accessor cache) per thread and call.
    static std::atomic<std::uint64_t> calls{0};
    const std::uint64_t call = ++calls;
    auto value = [&grid, iso, sign, call](const glm::vec3& p) {
        thread_local std::uint64_t owner = 0;
        thread_local std::unique_ptr<
            openvdb::tools::GridSampler<openvdb::FloatGrid::ConstAccessor, openvdb::tools::BoxSampler>>
            s;
        thread_local std::unique_ptr<openvdb::FloatGrid::ConstAccessor> acc;
        if (owner != call) {
            acc = std::make_unique<openvdb::FloatGrid::ConstAccessor>(grid.getConstAccessor());
            s = std::make_unique<
                openvdb::tools::GridSampler<openvdb::FloatGrid::ConstAccessor, openvdb::tools::BoxSampler>>(
                *acc, grid.transform());
            owner = call;
        }
        return sign * (s->isSample(openvdb::Vec3d(p.x, p.y, p.z)) - iso);
    };
    sharpen(mesh, value, stats);
}

}  // namespace isoforge::volume
