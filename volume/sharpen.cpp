#include "volume/sharpen.h"

#include "mesh/self_intersections.h"

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

constexpr float kStep = 1e-3f;  // central differences of the field, in voxels

/// The six points of the central differences at p, appended to `out`.
void appendStencil(const glm::vec3& p, std::vector<glm::vec3>& out) {
    for (int k = 0; k < 3; ++k) {
        glm::vec3 a = p, b = p;
        a[k] -= kStep;
        b[k] += kStep;
        out.push_back(a);
        out.push_back(b);
    }
}

/// The gradient from the values at appendStencil's six points.
glm::vec3 stencilGradient(const float* v) {
    return glm::vec3(v[1] - v[0], v[3] - v[2], v[5] - v[4]) / (2.f * kStep);
}

/// The field's gradient at each point: its own where it gives one (the active branch of a min or
/// max, exactly), else central differences of its values.
void gradientsAt(const IndexValues& f, std::span<const glm::vec3> p, std::vector<glm::vec3>& out) {
    out.resize(p.size());
    if (f.gradients) {
        f.gradients(p, out);
        return;
    }
    std::vector<glm::vec3> pts;
    pts.reserve(6 * p.size());
    for (const glm::vec3& q : p) appendStencil(q, pts);
    std::vector<float> v(pts.size());
    f(pts, v);
    for (std::size_t i = 0; i < p.size(); ++i) out[i] = stencilGradient(&v[6 * i]);
}

/// An index-space box grown point by point.
struct Bounds {
    glm::vec3 lo{std::numeric_limits<float>::infinity()}, hi{-std::numeric_limits<float>::infinity()};
    void add(const glm::vec3& p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    /// The field there, with room for the central differences around every point added.
    IndexValues of(const IndexField& field) const { return field(lo - 4.f * kStep, hi + 4.f * kStep); }
};

/// Batches: vertices, cells and crease candidates are taken this many at a time, neighbours in the
/// mesh's order (marching cubes writes block by block), so that each batch asks for a small box.
constexpr std::size_t kBatch = 64;

std::size_t batchCount(std::size_t n) {
    return (n + kBatch - 1) / kBatch;
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

/// Follows creases across cells (Kobbelt et al.'s edge flip): two fan triangles (c1, a, b) and
/// (c2, b, a) of face-neighbouring cells, with feature vertices c1 and c2, become (c1, a, c2) and
/// (c1, c2, b) when the field's normals at their centres agree better with the new pair. Both new
/// triangles lie in the box of the two cells and meet its boundary only at a or b, so only the
/// triangles of those two cells (and earlier flips into them) can cross them: each flip is tested
/// against those with exact predicates and skipped if any pair intersects, or if c1-c2 is already an
/// edge (the mesh would stop being manifold). Edges in a fixed order, each triangle flipped once.
std::size_t flipCreases(const std::vector<glm::vec3>& P, std::vector<glm::uvec3>& tris,
                        const std::vector<std::int64_t>& cellOf, unsigned firstApex, std::size_t cellCount,
                        const IndexField& field) {
    auto isApex = [&](unsigned v) { return v >= firstApex; };
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
        if (j - i >= 2 && tris[t1].x != tris[t2].x && !isApex(unsigned(key >> 32)) &&
            !isApex(unsigned(key & 0xffffffffu)))
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
        for (unsigned v : loop) {
            glm::dvec3 n(gradient[v]);
            const double len = glm::length(n);
            if (!(len > 0) || !std::isfinite(len)) continue;
            n /= len;
            A += glm::outerProduct(n, n);
            b += n * glm::dot(n, glm::dvec3(P[v]) - mass);
            normalSum += n;
        }
        glm::dvec3 lambda;
        glm::dmat3 V;
        int rank = 0;
        glm::dvec3 x(0.0);
        // An eigenvector is kept (a normal direction of the data) when its eigenvalue passes the rank cutoff.
        auto kept = [&](int k) { return lambda[k] > 0.1 * std::max({lambda.x, lambda.y, lambda.z}); };
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
        auto fanIsGraphOver = [&](glm::dvec3 D) {
            D = glm::normalize(D);
            const glm::dvec3 U = glm::normalize(std::abs(D.x) < 0.9 ? glm::cross(D, glm::dvec3(1, 0, 0))
                                                                    : glm::cross(D, glm::dvec3(0, 1, 0)));
            const glm::dvec3 W = glm::cross(D, U);
            double turn = 0;
            for (std::size_t k = 0; k < loop.size(); ++k) {
                const glm::dvec3 a = glm::dvec3(P[loop[k]]) - c, d = glm::dvec3(P[loop[(k + 1) % loop.size()]]) - c;
                const glm::dvec2 a2(glm::dot(a, U), glm::dot(a, W)), d2(glm::dot(d, U), glm::dot(d, W));
                const double cr = a2.x * d2.y - a2.y * d2.x;
                if (!(cr > 1e-9 * (glm::dot(a2, a2) + glm::dot(d2, d2)))) return false;
                turn += std::atan2(cr, glm::dot(a2, d2));
            }
            return std::abs(turn - 2.0 * M_PI) < 1e-3;
        };
        bool graph = fanIsGraphOver(N) || (glm::length(normalSum) > 0 && fanIsGraphOver(normalSum));
        for (int k = 0; k < 3 && !graph; ++k)
            if (kept(k)) graph = fanIsGraphOver(glm::dot(V[k], N) >= 0 ? V[k] : -V[k]);
        if (!graph) {
            result[ci] = 3;
            return;
        }
        std::copy(loop.begin(), loop.end(), loops.begin() + std::ptrdiff_t(cellStart[ci] + 2 * ci));
        apex[ci] = glm::vec3(c);
        result[ci] = 1;
    });

    // 4. The mesh again, in its order: a sharpened patch's fan where its first triangle was.
    std::vector<std::int64_t> patchOfTriangle(mesh.triangles.size(), -1);
    for (std::size_t ci = 0; ci < cellCount; ++ci) {
        stats.patches += result[ci] != 4;
        stats.features += result[ci] == 1;
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
    std::vector<char> emitted(cellCount, 0);
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
    stats.flips = flipCreases(P, out, cellOfOut, firstApex, cellCount, field);
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
