#include "volume/sharpen.h"

#include "volume/crease_flips.h"
#include "volume/hermite.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <openvdb/tools/Interpolation.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/vector_relational.hpp>

namespace isoforge::volume {

using namespace hermite;

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

/// Marching cubes makes at most 5 triangles in a cell; a cell with more is left as it is.
constexpr std::size_t kMaxTriangles = 8;

/// A patch's boundary vertices in the patch's orientation, while it is being followed: at most one
/// per directed edge of its triangles, and one more (a loop that does not close).
struct Loop {
    std::array<unsigned, 3 * kMaxTriangles + 1> v{};
    std::size_t n = 0;
    std::size_t size() const { return n; }
    unsigned operator[](std::size_t i) const { return v[i]; }
    unsigned front() const { return v[0]; }
    unsigned back() const { return v[n - 1]; }
    void push_back(unsigned x) { v[n++] = x; }
    const unsigned* begin() const { return v.data(); }
    const unsigned* end() const { return v.data() + n; }
};

/// A patch's feature point may lie this many cells beyond its own cell along each axis (docs/marching-cubes.md).
constexpr int kReachCells = 4;
/// ... and only when it lies further than this (voxels) from its nearest point in the cell: nearer, the
/// point brought in is as good, and its fan can still be flipped along a crease.
constexpr double kReachBeyond = 0.05;

/// A patch whose feature point lies beyond its cell, in empty cells: the box of cells [lo, hi] from its own
/// cell to the point's, and the apex in it.
struct Reach {
    glm::ivec3 own{0}, lo{0}, hi{0};
    glm::vec3 apex{0.f};
    bool wanted = false;  // the box is empty, the field agrees and the fan from the apex is a graph
};

/// Calls f on each cell of the reach's box but its own.
template <class F>
void forEachCell(const Reach& r, F&& f) {
    for (int x = r.lo.x; x <= r.hi.x; ++x)
        for (int y = r.lo.y; y <= r.hi.y; ++y)
            for (int z = r.lo.z; z <= r.hi.z; ++z)
                if (glm::ivec3(x, y, z) != r.own) f(glm::ivec3(x, y, z));
}

}  // namespace

void sharpen(mesh::TriMesh& mesh, const IndexField& field, SharpenStats* statsOut, const openvdb::FloatGrid* samples) {
    SharpenStats stats;
    auto& P = mesh.positions;
    const std::size_t nv = P.size();

    // 1. Exact crossings: each vertex moved onto the field's zero along its edge (regula falsi, Illinois
    // variant, the searches of a batch of vertices in step), then the field's gradient at each vertex.
    std::vector<Edge> edges(nv);
    std::vector<char> moved(nv, 0);
    std::vector<glm::vec3> gradient(nv);
    tbb::parallel_for(std::size_t{0}, batchCount(nv), [&](std::size_t batch) {
        const std::size_t begin = batch * kBatch, end = std::min(nv, begin + kBatch), n = end - begin;
        Bounds box;
        for (std::size_t i = begin; i < end; ++i) {
            edges[i] = edgeOf(P[i]);
            glm::vec3 b(edges[i].corner);
            box.add(b);
            b[edges[i].axis] += 1.f;
            box.add(b);
        }
        const IndexValues values = box.of(field);
        auto pointOn = [&](std::size_t i, float t) {
            glm::vec3 q(edges[i].corner);
            q[edges[i].axis] += t;
            return q;
        };
        std::vector<glm::vec3> pts;
        pts.reserve(6 * n);
        for (std::size_t i = begin; i < end; ++i) {
            pts.push_back(pointOn(i, 0.f));
            pts.push_back(pointOn(i, 1.f));
        }
        std::vector<float> v(pts.size());
        if (samples) {
            // The ends are grid points: their values are the grid's where it holds them (active voxels);
            // the field is asked only for the others.
            const openvdb::FloatGrid::ConstAccessor acc = samples->getConstAccessor();
            std::vector<glm::vec3> missing;
            std::vector<std::size_t> at;
            for (std::size_t k = 0; k < pts.size(); ++k)
                if (!acc.probeValue(openvdb::Coord(int(pts[k].x), int(pts[k].y), int(pts[k].z)), v[k])) {
                    missing.push_back(pts[k]);
                    at.push_back(k);
                }
            if (!missing.empty()) {
                std::vector<float> mv(missing.size());
                values(missing, mv);
                for (std::size_t k = 0; k < at.size(); ++k) v[at[k]] = mv[k];
            }
        } else {
            values(pts, v);
        }
        struct Search {
            float ta = 0.f, tb = 1.f, fa, fb, t = 0.5f, tolerance;
            int side = 0;
        };
        std::vector<Search> search(n);
        std::vector<std::size_t> active;  // offsets in the batch
        for (std::size_t j = 0; j < n; ++j) {
            search[j].fa = v[2 * j];
            search[j].fb = v[2 * j + 1];
            search[j].tolerance = 1e-5f * (std::abs(search[j].fa) + std::abs(search[j].fb));
            // Where the field does not cross (the grid's sign differs), the vertex stays.
            if (search[j].fa * search[j].fb < 0.f) active.push_back(j);
        }
        const std::vector<std::size_t> crossing = active;
        for (int it = 0; it < 24 && !active.empty(); ++it) {
            pts.clear();
            for (std::size_t j : active) {
                Search& s = search[j];
                s.t = (s.ta * s.fb - s.tb * s.fa) / (s.fb - s.fa);
                if (!(s.t > s.ta && s.t < s.tb)) s.t = 0.5f * (s.ta + s.tb);
                pts.push_back(pointOn(begin + j, s.t));
            }
            v.resize(pts.size());
            values(pts, v);
            std::size_t kept = 0;
            for (std::size_t k = 0; k < active.size(); ++k) {
                Search& s = search[active[k]];
                const float ft = v[k];
                // Found: within 1e-5 of the ends' values of the zero (for a distance, 1e-5 of a voxel), which takes
                // in a surface as a field marks it (a polyhedron's least negative float within a few ulps of it).
                if (std::abs(ft) <= s.tolerance || s.tb - s.ta < 1e-6f) continue;
                if ((ft < 0.f) == (s.fa < 0.f)) {
                    s.ta = s.t;
                    s.fa = ft;
                    if (s.side == -1) s.fb *= 0.5f;
                    s.side = -1;
                } else {
                    s.tb = s.t;
                    s.fb = ft;
                    if (s.side == 1) s.fa *= 0.5f;
                    s.side = 1;
                }
                active[kept++] = active[k];
            }
            active.resize(kept);
        }
        for (std::size_t j : crossing) {
            P[begin + j] = pointOn(begin + j, std::clamp(search[j].t, kMargin, 1.f - kMargin));
            moved[begin + j] = 1;
        }
        // The field's normal at every crossing (the Hermite data of step 3), once per vertex.
        std::vector<glm::vec3> g;
        gradientsAt(values, std::span<const glm::vec3>(P.data() + begin, n), g);
        std::copy(g.begin(), g.end(), gradient.begin() + std::ptrdiff_t(begin));
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
    // Block-major: the cells of an 8^3 block of the grid are neighbours in key order, so the field pruned
    // to a block (PrunedField in surface.cpp) serves all of them in turn; x-major order went through a
    // whole slab of blocks for each x and pruned each block eight times over.
    auto key = [](const glm::ivec3& c) {
        const glm::uvec3 u = glm::uvec3(c) & 0x1fffffu;
        const glm::uvec3 block = u >> 3u, in = u & 7u;
        return (std::uint64_t(block.x) << 45) | (std::uint64_t(block.y) << 27) | (std::uint64_t(block.z) << 9) |
               (in.x << 6) | (in.y << 3) | in.z;
    };
    // A triangle's cells: those around all three of its vertices' edges (none, one, or more when
    // ambiguous), found in parallel; then gathered in mesh order.
    const std::size_t nt = mesh.triangles.size();
    std::vector<std::array<std::uint64_t, 4>> common(nt);
    std::vector<std::uint8_t> commonCount(nt);
    tbb::parallel_for(std::size_t{0}, nt, [&](std::size_t t) {
        std::array<std::array<glm::ivec3, 4>, 3> c;
        for (int k = 0; k < 3; ++k) cellsOf(mesh.triangles[t][k], c[k]);
        std::uint8_t n = 0;
        for (const auto& a : c[0])
            if (std::find(c[1].begin(), c[1].end(), a) != c[1].end() &&
                std::find(c[2].begin(), c[2].end(), a) != c[2].end())
                common[t][n++] = key(a);
        commonCount[t] = n;
    });
    std::vector<std::pair<std::uint64_t, std::size_t>> owned;  // (cell, triangle)
    owned.reserve(nt);
    std::vector<std::uint64_t> ambiguous;
    for (std::size_t t = 0; t < nt; ++t) {
        const std::size_t n = commonCount[t];
        if (n == 0) continue;  // not a marching cubes triangle: left alone
        owned.emplace_back(common[t][0], t);
        for (std::size_t k = 1; k < n; ++k) ambiguous.push_back(common[t][k]);
        if (n > 1) ambiguous.push_back(common[t][0]);
    }
    std::vector<std::array<std::uint64_t, 4>>().swap(common);
    std::sort(ambiguous.begin(), ambiguous.end());
    // Cells in key order (a deterministic walk), each with its triangles in mesh order.
    tbb::parallel_sort(owned.begin(), owned.end());
    std::vector<std::uint64_t> cellKey;
    std::vector<std::size_t> cellStart, cellTris(owned.size());
    for (std::size_t k = 0; k < owned.size(); ++k) {
        if (k == 0 || owned[k].first != owned[k - 1].first) {
            cellKey.push_back(owned[k].first);
            cellStart.push_back(k);
        }
        cellTris[k] = owned[k].second;
    }
    cellStart.push_back(owned.size());
    const std::size_t cellCount = cellKey.size();
    auto trianglesOf = [&](std::size_t ci) {
        return std::span<const std::size_t>(cellTris.data() + cellStart[ci], cellStart[ci + 1] - cellStart[ci]);
    };

    // 3. Per cell: one patch, its boundary loop, the QEF's point, the checks.
    // A sharpened patch's loop: as many vertices as its triangles and two more (a disk), kept in one
    // array at the cell's triangles' offset plus two per cell before it.
    std::vector<unsigned> loops(owned.size() + 2 * cellCount);
    auto loopOf = [&](std::size_t ci) {
        return std::span<const unsigned>(loops.data() + cellStart[ci] + 2 * ci, trianglesOf(ci).size() + 2);
    };
    std::vector<glm::vec3> apex(cellCount);
    // A patch whose point lies beyond its cell: the box of cells from its own to the point's, and where in
    // it the apex would go.
    std::vector<Reach> reaches(cellCount);
    auto hasTriangles = [&](const glm::ivec3& q) {
        const std::uint64_t k = key(q);
        return std::binary_search(cellKey.begin(), cellKey.end(), k) ||
               std::binary_search(ambiguous.begin(), ambiguous.end(), k);
    };
    auto reachable = [&](const glm::ivec3& own, const glm::dvec3& target, const glm::dvec3& outward,
                         const glm::dvec3& mass, Reach& r) {
        if (!(std::isfinite(target.x) && std::isfinite(target.y) && std::isfinite(target.z))) return false;
        const glm::dvec3 t = glm::floor(target);
        if (glm::any(glm::greaterThan(glm::abs(t - glm::dvec3(own)), glm::dvec3(kReachCells)))) return false;
        r.own = own;
        r.lo = glm::min(own, glm::ivec3(t));
        r.hi = glm::max(own, glm::ivec3(t));
        bool empty = true;
        forEachCell(r, [&](const glm::ivec3& q) { empty = empty && !hasTriangles(q); });
        if (!empty) return false;
        const glm::dvec3 a =
            glm::clamp(target, glm::dvec3(r.lo) + double(kMargin), glm::dvec3(r.hi + 1) - double(kMargin));
        // The field must agree: the apex on its surface (within 0.1 voxel), the way from the patch to it
        // inside the solid for a point outward of the patch (a tip), outside for one inward (a notch).
        std::array<glm::vec3, 4> q{glm::vec3(a)};
        Bounds box;
        box.add(q[0]);
        box.add(glm::vec3(mass));
        for (int k = 1; k < 4; ++k) q[std::size_t(k)] = glm::vec3(mass + (a - mass) * (0.25 * k));
        const IndexValues there = box.of(field);
        std::array<float, 4> f;
        there(q, f);
        std::vector<glm::vec3> g;
        gradientsAt(there, std::span<const glm::vec3>(q.data(), 1), g);
        const double len = glm::length(glm::dvec3(g[0]));
        if (!(len > 0) || !(std::abs(double(f[0])) / len <= 0.1)) return false;
        const float side = glm::dot(a - mass, outward) > 0 ? -1.f : 1.f;
        for (int k = 1; k < 4; ++k)
            if (!(f[std::size_t(k)] * side > 0.f)) return false;
        r.apex = glm::vec3(a);
        return true;
    };
    std::vector<char> result(cellCount, 0);  // 1 feature vertex, 2 flat, 3 kept, 4 several patches
    tbb::parallel_for(std::size_t{0}, cellCount, [&](std::size_t ci) {
        const std::span<const std::size_t> tris = trianglesOf(ci);
        if (tris.size() > kMaxTriangles || std::binary_search(ambiguous.begin(), ambiguous.end(), cellKey[ci])) {
            result[ci] = 4;
            return;
        }
        // Directed edges; the patch is one disk when no directed edge repeats and the unpaired ones (the
        // boundary, at most one leaving each vertex) form one cycle.
        using DirectedEdge = std::pair<unsigned, unsigned>;
        std::array<DirectedEdge, 3 * kMaxTriangles> directed, next;
        std::size_t nd = 0, nn = 0;
        for (std::size_t t : tris)
            for (int k = 0; k < 3; ++k) directed[nd++] = {mesh.triangles[t][k], mesh.triangles[t][(k + 1) % 3]};
        bool ok = true;
        for (std::size_t i = 0; i < nd && ok; ++i) {
            const DirectedEdge e = directed[i];
            bool paired = false;
            for (std::size_t j = 0; j < nd; ++j) {
                if (j != i && directed[j] == e) ok = false;
                if (directed[j] == DirectedEdge{e.second, e.first}) paired = true;
            }
            if (paired) continue;
            for (std::size_t j = 0; j < nn; ++j)
                if (next[j].first == e.first) ok = false;
            next[nn++] = e;
        }
        if (!ok || nn < 3) {
            result[ci] = 4;
            return;
        }
        std::sort(next.begin(), next.begin() + std::ptrdiff_t(nn));  // the loop starts at its lowest vertex
        Loop loop;
        loop.push_back(next[0].first);
        while (loop.size() <= nn) {
            const auto it = std::find_if(next.begin(), next.begin() + std::ptrdiff_t(nn),
                                         [&](const DirectedEdge& e) { return e.first == loop.back(); });
            if (it == next.begin() + std::ptrdiff_t(nn)) break;
            if (it->second == loop.front()) break;
            loop.push_back(it->second);
        }
        if (loop.size() != nn) {  // several loops: several patches
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
        glm::dvec3 b(0.0), normalSum(0.0);  // normalSum: the Hermite normals' sum, a second fold-test direction
        std::array<glm::dvec3, 3 * kMaxTriangles + 1> unitNormals;
        std::size_t normalCount = 0;
        for (unsigned v : loop) {
            glm::dvec3 n(gradient[v]);
            const double len = glm::length(n);
            if (!(len > 0) || !std::isfinite(len)) continue;
            n /= len;
            A += glm::outerProduct(n, n);
            b += n * glm::dot(n, glm::dvec3(P[v]) - mass);
            normalSum += n;
            unitNormals[normalCount++] = n;
        }
        // Normals more than 134 degrees apart in one cell: a thin wedge (two faces meeting at under 46
        // degrees), which the cutoff below would take for one flat face (their quadric's two eigenvalues are
        // 1 -+ cos of the angle). A smooth surface turns that far within a cell only where its radius is
        // under a voxel.
        bool opposed = false;
        for (std::size_t i = 0; i < normalCount && !opposed; ++i)
            for (std::size_t j = i + 1; j < normalCount && !opposed; ++j)
                opposed = glm::dot(unitNormals[i], unitNormals[j]) < -0.7;
        glm::dvec3 lambda;
        glm::dmat3 V;
        int rank = 0;
        glm::dvec3 x(0.0);
        // An eigenvector is kept (a normal direction of the data) when its eigenvalue passes the rank cutoff;
        // for a thin wedge, its second direction down to 1/1000 of the largest (wedges down to 3.6 degrees).
        auto kept = [&](int k) {
            const double top = std::max({lambda.x, lambda.y, lambda.z});
            if (lambda[k] > 0.1 * top) return true;
            if (!opposed || !(lambda[k] > 1e-3 * top)) return false;
            int above = 0;  // the second largest only
            for (int j = 0; j < 3; ++j) above += j != k && lambda[j] > lambda[k];
            return above == 1;
        };
        auto solve = [&] {
            jacobi(A, lambda, V);
            rank = 0;
            x = glm::dvec3(0.0);
            for (int k = 0; k < 3; ++k) {
                if (!kept(k)) continue;
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
            const IndexValues there = field(q - 4.f * kStep, q + 4.f * kStep);
            float f;
            there(std::span<const glm::vec3>(&q, 1), std::span<float>(&f, 1));
            std::vector<glm::vec3> gs;
            gradientsAt(there, std::span<const glm::vec3>(&q, 1), gs);
            const glm::vec3 gq = gs[0];
            const double len = glm::length(glm::dvec3(gq));
            if (!(len > 0) || !std::isfinite(len)) break;
            const double dist = double(f) / len;  // in voxels
            if (!(std::abs(dist) > 0.02) || std::abs(dist) > 1.0) break;
            const glm::dvec3 n = glm::dvec3(gq) / len;
            const glm::dvec3 onSurface = glm::dvec3(q) - dist * n;
            A += glm::outerProduct(n, n);
            b += n * glm::dot(n, onSurface - mass);
            normalSum += n;
            solve();
        }
        glm::dvec3 c = mass + x;
        const glm::dvec3 target = c;  // the QEF's own point, before it is brought into the cell
        // The cell's lower corner: the smallest corner of its crossings' edges.
        glm::dvec3 cellLo = glm::dvec3(1e30);
        for (unsigned v : loop) cellLo = glm::min(cellLo, glm::dvec3(edges[v].corner));
        const glm::dvec3 boxLo = cellLo + double(kMargin), boxHi = cellLo + (1.0 - double(kMargin));
        auto inBox = [&](const glm::dvec3& q) {
            return q.x >= boxLo.x && q.x <= boxHi.x && q.y >= boxLo.y && q.y <= boxHi.y && q.z >= boxLo.z &&
                   q.z <= boxHi.z;
        };
        bool reach = false;  // the point lies well outside the cell and the crease does not cross it
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
            // Only a point well beyond the cell: one just past a face (an edge on a grid plane) is as good
            // brought in, where its fan can still be flipped along the crease.
            reach = !onCrease && glm::length(target - c) > kReachBeyond;
        }
        // No fold: the fan is a graph over a plane. Every fan triangle turns the patch's way in the plane
        // across a direction D, and the loop goes once around the apex there. D is the patch's normal, else
        // the Hermite normals' mean, else each normal direction the quadric kept: across a sharp ridge
        // marching cubes' chamfer leans away from the ridge point, which a plane across the two faces'
        // bisector, or across one face, still sees inside the loop.
        glm::dvec3 N(0.0);
        for (std::size_t t : tris) {
            const glm::dvec3 p0(P[mesh.triangles[t][0]]), p1(P[mesh.triangles[t][1]]), p2(P[mesh.triangles[t][2]]);
            N += glm::cross(p1 - p0, p2 - p0);
        }
        if (!(glm::length(N) > 0)) {
            result[ci] = 3;
            return;
        }
        auto fanIsGraphOver = [&](glm::dvec3 D, const glm::dvec3& from) {
            D = glm::normalize(D);
            const glm::dvec3 U = glm::normalize(std::abs(D.x) < 0.9 ? glm::cross(D, glm::dvec3(1, 0, 0))
                                                                    : glm::cross(D, glm::dvec3(0, 1, 0)));
            const glm::dvec3 W = glm::cross(D, U);
            double turn = 0;
            for (std::size_t k = 0; k < loop.size(); ++k) {
                const glm::dvec3 a = glm::dvec3(P[loop[k]]) - from,
                                 d = glm::dvec3(P[loop[(k + 1) % loop.size()]]) - from;
                const glm::dvec2 a2(glm::dot(a, U), glm::dot(a, W)), d2(glm::dot(d, U), glm::dot(d, W));
                const double cr = a2.x * d2.y - a2.y * d2.x;
                if (!(cr > 1e-9 * (glm::dot(a2, a2) + glm::dot(d2, d2)))) return false;
                turn += std::atan2(cr, glm::dot(a2, d2));
            }
            return std::abs(turn - 2.0 * M_PI) < 1e-3;
        };
        auto graphFrom = [&](const glm::dvec3& from) {
            bool graph = fanIsGraphOver(N, from) || (glm::length(normalSum) > 0 && fanIsGraphOver(normalSum, from));
            for (int k = 0; k < 3 && !graph; ++k)
                if (kept(k)) graph = fanIsGraphOver(glm::dot(V[k], N) >= 0 ? V[k] : -V[k], from);
            // Last, the way from the crossings' mean to the point: seen along it the point lies over the
            // mean, inside the loop where the loop is star-shaped around it (a corner cut off by one
            // triangle whose corner lies on the cell's edge, where no normal of the data sees it inside).
            const glm::dvec3 out = from - mass;
            if (!graph && glm::length(out) > 0 && glm::dot(out, N) != 0)
                graph = fanIsGraphOver(glm::dot(out, N) > 0 ? out : -out, from);
            return graph;
        };
        const bool graph = graphFrom(c);
        if (graph || reach) std::copy(loop.begin(), loop.end(), loops.begin() + std::ptrdiff_t(cellStart[ci] + 2 * ci));
        if (reach) {
            Reach& r = reaches[ci];
            const glm::ivec3 own(cellLo);
            if (reachable(own, target, glm::normalize(N), mass, r) && graphFrom(glm::dvec3(r.apex))) r.wanted = true;
        }
        apex[ci] = glm::vec3(c);
        result[ci] = graph ? 1 : 3;
    });

    // 3b. Reaching into empty cells, in key order: a feature point beyond its cell (a cone's tip or a thin
    // wedge's edge that no grid edge crosses) is taken where the box of cells from the patch's cell to the
    // point holds no triangle and no other patch has taken any of those cells.
    std::vector<char> reached(cellCount, 0);
    {
        std::unordered_set<std::uint64_t> taken;
        for (std::size_t ci = 0; ci < cellCount; ++ci) {
            const Reach& r = reaches[ci];
            if (!r.wanted) continue;
            bool free = true;
            forEachCell(r, [&](const glm::ivec3& q) { free = free && !taken.count(key(q)); });
            if (!free) continue;
            forEachCell(r, [&](const glm::ivec3& q) { taken.insert(key(q)); });
            apex[ci] = r.apex;
            result[ci] = 1;
            reached[ci] = 1;
        }
    }

    // 4. The mesh again, in its order: a sharpened patch's fan where its first triangle was.
    std::vector<std::int64_t> patchOfTriangle(mesh.triangles.size(), -1);
    for (std::size_t ci = 0; ci < cellCount; ++ci) {
        stats.patches += result[ci] != 4;
        stats.features += result[ci] == 1;
        stats.reached += reached[ci];
        stats.flat += result[ci] == 2;
        stats.kept += result[ci] == 3;
        stats.sharedCells += result[ci] == 4;
        if (result[ci] == 1)
            for (std::size_t t : trianglesOf(ci)) patchOfTriangle[t] = std::int64_t(ci);
    }
    std::vector<glm::uvec3> out;
    std::vector<std::int64_t> cellOfOut;  // each output triangle's cell (its index), -1 if none
    std::vector<std::int64_t> cellOfTriangle(mesh.triangles.size(), -1);
    for (std::size_t ci = 0; ci < cellCount; ++ci)
        for (std::size_t t : trianglesOf(ci)) cellOfTriangle[t] = std::int64_t(ci);
    out.reserve(mesh.triangles.size() + 2 * stats.features);
    cellOfOut.reserve(out.capacity());
    P.reserve(P.size() + stats.features);
    const auto firstApex = static_cast<unsigned>(P.size());
    std::vector<char> emitted(cellCount, 0), reachingApex;
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
        reachingApex.push_back(reached[ci]);
        const std::span<const unsigned> loop = loopOf(std::size_t(ci));
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
    stats.flips = flipCreases(P, out, cellOfOut, firstApex, cellCount, field, reachingApex);
    mesh.triangles = std::move(out);
    if (statsOut) *statsOut = stats;
}

}  // namespace isoforge::volume

namespace isoforge::volume {

IndexField pointwise(std::function<float(const glm::vec3&)> value) {
    return [value = std::move(value)](const glm::vec3&, const glm::vec3&) -> IndexValues {
        return [&value](std::span<const glm::vec3> p, std::span<float> out) {
            for (std::size_t i = 0; i < p.size(); ++i) out[i] = value(p[i]);
        };
    };
}

void sharpenWithGrid(mesh::TriMesh& mesh, const openvdb::FloatGrid& grid, float iso, bool insideBelow,
                     SharpenStats* stats) {
    const float sign = insideBelow ? 1.f : -1.f;
    auto values = [&grid, iso, sign](std::span<const glm::vec3> p, std::span<float> out) {
        // One accessor (and its cache) per batch: batches run on several threads.
        const openvdb::FloatGrid::ConstAccessor acc = grid.getConstAccessor();
        const openvdb::tools::GridSampler<openvdb::FloatGrid::ConstAccessor, openvdb::tools::BoxSampler> s(
            acc, grid.transform());
        for (std::size_t i = 0; i < p.size(); ++i)
            out[i] = sign * (s.isSample(openvdb::Vec3d(p[i].x, p[i].y, p[i].z)) - iso);
    };
    sharpen(
        mesh, [&values](const glm::vec3&, const glm::vec3&) -> IndexValues { return values; }, stats);
}

}  // namespace isoforge::volume
