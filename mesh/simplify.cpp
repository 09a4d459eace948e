#include "mesh/simplify.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <queue>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include "mesh/loose_octree.h"
#include "mesh/self_intersections.h"

// Why our own: meshoptimizer 0.18's simplifier (Debian 12) does not guarantee manifold output
// (zeux/meshoptimizer#699) nor freedom from overlaps (#86); CGAL 5.5's Surface_mesh_simplification
// keeps the manifold but guards neither self-intersections nor a distance to the original, and its
// filters see one collapse at a time without a structure to test new triangles against the rest.
// Here each collapse is tested against the current triangles near it (a loose octree,
// mesh/loose_octree.h) with the exact pair test of mesh/self_intersections.cpp.

namespace isoforge::mesh {

namespace {

using dvec3 = glm::dvec3;

constexpr std::size_t kMaxOwned = 1024;  // original vertices a collapse may reassign
constexpr std::uint8_t kMaxRetries = 2;  // times a refused edge is offered again after collapses next to it
constexpr double kTurn = 0.0;            // cos of the most a triangle may turn in one collapse: 90 degrees, never over
// Added to the quadric error, times the edge's squared length: among collapses of (almost) equal error, the
// shorter edge goes first. On a flat region every error is zero up to rounding; ordered by vertex number
// instead, one vertex swallowed its neighbours one after another into a fan of ever longer slivers (valence
// 45 on average on the plate at 128 voxels), whose every later collapse was refused or cost a thousand pair
// tests: 31 s there, 2.1 s with it, and 1,834 triangles instead of 3,894.
constexpr double kLengthWeight = 1e-2;

/// A symmetric 4x4 quadric: the sum of squared distances to planes.
struct Quadric {
    double a[10] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0};  // xx xy xz xw yy yz yw zz zw ww
    void addPlane(const dvec3& n, double d) {
        const double v[4] = {n.x, n.y, n.z, d};
        int k = 0;
        for (int i = 0; i < 4; ++i)
            for (int j = i; j < 4; ++j) a[k++] += v[i] * v[j];
    }
    Quadric& operator+=(const Quadric& o) {
        for (int i = 0; i < 10; ++i) a[i] += o.a[i];
        return *this;
    }
    double error(const dvec3& p) const {
        const double x = p.x, y = p.y, z = p.z;
        return a[0] * x * x + 2 * a[1] * x * y + 2 * a[2] * x * z + 2 * a[3] * x + a[4] * y * y + 2 * a[5] * y * z +
               2 * a[6] * y + a[7] * z * z + 2 * a[8] * z + a[9];
    }
    /// The minimizer, if the 3x3 part is well conditioned.
    bool optimum(dvec3& p) const {
        const glm::dmat3 m(a[0], a[1], a[2], a[1], a[4], a[5], a[2], a[5], a[7]);
        const double det = glm::determinant(m);
        const double scale = a[0] * a[4] * a[7];
        if (!(std::abs(det) > 1e-9 * std::max(scale, 1e-300))) return false;
        p = glm::inverse(m) * dvec3(-a[3], -a[6], -a[8]);
        return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
    }
};

/// Distance from p to the triangle (a, b, c) (Ericson, Real-Time Collision Detection, 5.1.5).
double pointTriangle(const dvec3& p, const dvec3& a, const dvec3& b, const dvec3& c) {
    const dvec3 ab = b - a, ac = c - a, ap = p - a;
    const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return glm::length(ap);
    const dvec3 bp = p - b;
    const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return glm::length(bp);
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return glm::length(p - (a + ab * (d1 / (d1 - d3))));
    const dvec3 cp = p - c;
    const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return glm::length(cp);
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return glm::length(p - (a + ac * (d2 / (d2 - d6))));
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
        return glm::length(p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))));
    const double denom = 1.0 / (va + vb + vc);
    return glm::length(p - (a + ab * (vb * denom) + ac * (vc * denom)));
}

struct Candidate {
    double cost;
    std::uint32_t u, v;
    std::uint32_t stampU, stampV;
    bool operator<(const Candidate& o) const {  // std::priority_queue is a max-heap: invert
        if (cost != o.cost) return cost > o.cost;
        if (u != o.u) return u > o.u;
        return v > o.v;
    }
};

class Simplifier {
public:
    Simplifier(TriMesh& m, double maxError) : m_(m), eps_(maxError) {
        const std::size_t nv = m.positions.size();
        P_.resize(nv);
        for (std::size_t i = 0; i < nv; ++i) P_[i] = dvec3(m.positions[i]);
        O_ = P_;
        T_ = m.triangles;
        alive_.assign(T_.size(), 1);
        vt_.resize(nv);
        origTris_.resize(nv);
        owned_.resize(T_.size());
        Q_.resize(nv);
        stamp_.assign(nv, 0);
        vertexAlive_.assign(nv, 1);
        parkedAt_.assign(nv, 0);
        double edgeSum = 0;
        for (std::uint32_t t = 0; t < T_.size(); ++t) {
            const auto& tri = T_[t];
            for (int k = 0; k < 3; ++k) {
                vt_[tri[k]].push_back(t);
                origTris_[tri[k]].push_back(t);
            }
            const dvec3 n = glm::cross(P_[tri.y] - P_[tri.x], P_[tri.z] - P_[tri.x]);
            const double len = glm::length(n);
            edgeSum += glm::length(P_[tri.y] - P_[tri.x]);
            if (len > 0) {
                const dvec3 u = n / len;
                for (int k = 0; k < 3; ++k) Q_[tri[k]].addPlane(u, -glm::dot(u, P_[tri.x]));
            }
        }
        origT_ = T_;
        for (std::uint32_t v = 0; v < nv; ++v)
            if (!vt_[v].empty()) owned_[vt_[v][0]].push_back(v);
        cell_ = std::max(2.0 * eps_, 2.0 * edgeSum / std::max<std::size_t>(T_.size(), 1));
        dvec3 lo(0.0), hi(0.0);
        if (nv > 0) lo = hi = P_[0];
        for (const dvec3& p : P_) {
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
        }
        // New vertices stay within maxError of the original surface: the margin keeps them inside.
        octree_.emplace(lo - 2.0 * eps_ - cell_, hi + 2.0 * eps_ + cell_, cell_);
        // Boxes are in double, the pair test sees the corners rounded to float: a margin far above that.
        const dvec3 far = glm::max(glm::abs(lo), glm::abs(hi));
        pad_ = 1e-6 * (std::max({far.x, far.y, far.z}) + cell_);
        for (std::uint32_t t = 0; t < T_.size(); ++t) insert(t);
        // The original triangles by grid cell (they never move), for the distance tests.
        for (std::uint32_t t = 0; t < origT_.size(); ++t) {
            dvec3 tlo, thi;
            bbox({O_[origT_[t].x], O_[origT_[t].y], O_[origT_[t].z]}, tlo, thi);
            const glm::ivec3 a(glm::floor(tlo / cell_)), b(glm::floor(thi / cell_));
            for (int x = a.x; x <= b.x; ++x)
                for (int y = a.y; y <= b.y; ++y)
                    for (int z = a.z; z <= b.z; ++z) origGrid_[key(x, y, z)].push_back(t);
        }
        local_.assign(origT_.size(), 0);
        own_.assign(origT_.size(), 0);
    }

    SimplifyStats run() {
        for (std::uint32_t t = 0; t < T_.size(); ++t)
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t a = T_[t][k], b = T_[t][(k + 1) % 3];
                if (a < b) push(a, b);
            }
        while (!heap_.empty()) {
            const Candidate c = heap_.top();
            heap_.pop();
            if (!vertexAlive_[c.u] || !vertexAlive_[c.v] || stamp_[c.u] != c.stampU || stamp_[c.v] != c.stampV)
                continue;
            tryCollapse(c.u, c.v);
        }
        finish();
        return stats_;
    }

private:
    dvec3 placement(std::uint32_t u, std::uint32_t v, double& cost) const {
        Quadric q = Q_[u];
        q += Q_[v];
        dvec3 best = 0.5 * (P_[u] + P_[v]);
        cost = q.error(best);
        dvec3 p;
        const double len = glm::length(P_[u] - P_[v]);
        if (q.optimum(p) && glm::length(p - best) < 2.0 * len) {
            const double e = q.error(p);
            if (e < cost) {
                cost = e;
                best = p;
            }
        }
        for (const dvec3& end : {P_[u], P_[v]}) {
            const double e = q.error(end);
            if (e < cost) {
                cost = e;
                best = end;
            }
        }
        cost = std::max(cost, 0.0);
        return best;
    }
    void push(std::uint32_t a, std::uint32_t b) {
        double cost;
        placement(a, b, cost);
        cost += kLengthWeight * glm::dot(P_[a] - P_[b], P_[a] - P_[b]);
        heap_.push({cost, a, b, stamp_[a], stamp_[b]});
    }
    void clean(std::uint32_t v) {
        auto& l = vt_[v];
        l.erase(std::remove_if(l.begin(), l.end(), [&](std::uint32_t t) { return !alive_[t]; }), l.end());
    }
    /// The vertices that share a live triangle with v, sorted, into n (a buffer kept between calls: no
    /// allocation per collapse).
    void neighbours(std::uint32_t v, std::vector<std::uint32_t>& n) const {
        n.clear();
        for (std::uint32_t t : vt_[v]) {
            if (!alive_[t]) continue;
            for (int k = 0; k < 3; ++k)
                if (T_[t][k] != v) n.push_back(T_[t][k]);
        }
        std::sort(n.begin(), n.end());
        n.erase(std::unique(n.begin(), n.end()), n.end());
    }
    void bbox(const std::array<dvec3, 3>& p, dvec3& lo, dvec3& hi) const {
        lo = glm::min(p[0], glm::min(p[1], p[2]));
        hi = glm::max(p[0], glm::max(p[1], p[2]));
    }
    /// Whether q lies within maxError of an original triangle that `allowed` accepts.
    template <class Allowed>
    bool nearOriginal(const dvec3& q, Allowed allowed) const {
        const glm::ivec3 a(glm::floor((q - eps_) / cell_)), b(glm::floor((q + eps_) / cell_));
        for (int x = a.x; x <= b.x; ++x)
            for (int y = a.y; y <= b.y; ++y)
                for (int z = a.z; z <= b.z; ++z) {
                    const auto it = origGrid_.find(key(x, y, z));
                    if (it == origGrid_.end()) continue;
                    for (std::uint32_t t : it->second) {
                        if (!allowed(t)) continue;
                        const auto& ot = origT_[t];
                        if (pointTriangle(q, O_[ot.x], O_[ot.y], O_[ot.z]) <= eps_) return true;
                    }
                }
        return false;
    }
    static std::int64_t key(int x, int y, int z) {
        return (std::int64_t(x & 0x1fffff) << 42) | (std::int64_t(y & 0x1fffff) << 21) | std::int64_t(z & 0x1fffff);
    }
    void insert(std::uint32_t t) {
        dvec3 lo, hi;
        bbox({P_[T_[t].x], P_[T_[t].y], P_[T_[t].z]}, lo, hi);
        octree_->insert(t, lo, hi);
    }

    void tryCollapse(std::uint32_t u, std::uint32_t v) {
        clean(u);
        clean(v);
        // The link condition: u and v share exactly the two vertices opposite their edge.
        auto& nu = scratch_.nu;
        auto& nv = scratch_.nv;
        neighbours(u, nu);
        neighbours(v, nv);
        auto& common = scratch_.common;
        common.clear();
        std::set_intersection(nu.begin(), nu.end(), nv.begin(), nv.end(), std::back_inserter(common));
        auto& ring = scratch_.ring;  // triangles of u or v
        auto& edgeTris = scratch_.edgeTris;
        ring.clear();
        edgeTris.clear();
        for (std::uint32_t t : vt_[u]) ring.push_back(t);
        for (std::uint32_t t : vt_[v])
            if (std::find(ring.begin(), ring.end(), t) == ring.end()) ring.push_back(t);
        for (std::uint32_t t : ring) {
            const auto& tr = T_[t];
            const bool hasU = tr.x == u || tr.y == u || tr.z == u, hasV = tr.x == v || tr.y == v || tr.z == v;
            if (hasU && hasV) edgeTris.push_back(t);
        }
        if (common.size() != 2 || edgeTris.size() != 2 || nu.size() <= 3 || nv.size() <= 3) {
            ++stats_.rejectedTopology;
            park(u, v);
            return;
        }
        // Placements by quadric error (the optimum, the midpoint, either end): the first that turns no
        // triangle over is taken.
        double cost;
        const dvec3 optimal = placement(u, v, cost);
        Quadric both = Q_[u];
        both += Q_[v];
        auto& options = scratch_.options;
        options.assign(1, {cost, optimal});
        for (const dvec3& o : {0.5 * (P_[u] + P_[v]), P_[u], P_[v]})
            if (o != optimal) options.emplace_back(std::max(both.error(o), 0.0), o);
        std::stable_sort(options.begin(), options.end(),
                         [](const auto& x, const auto& y) { return x.first < y.first; });
        dvec3 p(0.0);
        auto& fresh = scratch_.fresh;
        bool placed = false;
        for (const auto& option : options) {
            p = option.second;
            fresh.clear();
            bool ok = true;
            for (std::uint32_t t : ring) {
                if (t == edgeTris[0] || t == edgeTris[1]) continue;
                glm::uvec3 tr = T_[t];
                const dvec3 oldN = glm::cross(P_[tr.y] - P_[tr.x], P_[tr.z] - P_[tr.x]);
                for (int k = 0; k < 3; ++k)
                    if (tr[k] == v) tr[k] = u;
                auto pos = [&](std::uint32_t w) { return w == u ? p : P_[w]; };
                const dvec3 newN = glm::cross(pos(tr.y) - pos(tr.x), pos(tr.z) - pos(tr.x));
                const double lo = glm::length(oldN), ln = glm::length(newN);
                if (!(ln > 1e-12 * (lo + 1e-300)) || !(glm::dot(oldN, newN) > kTurn * lo * ln)) {
                    ok = false;
                    break;
                }
                fresh.push_back(tr);
            }
            if (ok) {
                placed = true;
                break;
            }
        }
        if (!placed) {
            ++stats_.rejectedFlip;
            park(u, v);
            return;
        }
        auto at = [&](std::uint32_t w) { return w == u ? p : P_[w]; };
        // Distance: the original vertices owned by the ring stay within maxError of the new triangles.
        auto& owners = scratch_.owners;  // original vertex -> index into fresh
        owners.clear();
        std::size_t ownedCount = 0;
        for (std::uint32_t t : ring) ownedCount += owned_[t].size();
        if (ownedCount > kMaxOwned) {  // triangles this large have simplified enough; keeps each collapse cheap
            ++stats_.rejectedError;
            return;
        }
        // The new triangle that replaces a ring triangle is where its owned vertices look first: one well
        // within the bound keeps them (on flat and gently curved regions the scan below is then skipped).
        auto& successor = scratch_.successor;
        successor.assign(ring.size(), fresh.size());
        for (std::size_t r = 0, f = 0; r < ring.size(); ++r)
            if (ring[r] != edgeTris[0] && ring[r] != edgeTris[1]) successor[r] = f++;
        for (std::size_t r = 0; r < ring.size(); ++r)
            for (std::uint32_t o : owned_[ring[r]]) {
                double best = 1e300;
                std::size_t arg = 0;
                if (successor[r] < fresh.size()) {
                    const glm::uvec3& tr = fresh[successor[r]];
                    best = pointTriangle(O_[o], at(tr.x), at(tr.y), at(tr.z));
                    arg = successor[r];
                }
                if (!(best <= 0.25 * eps_))
                    for (std::size_t f = 0; f < fresh.size(); ++f) {
                        const double d = pointTriangle(O_[o], at(fresh[f].x), at(fresh[f].y), at(fresh[f].z));
                        if (d < best) {
                            best = d;
                            arg = f;
                            if (d <= 1e-6 * eps_) break;  // on it (a flat region): no nearer owner to look for
                        }
                    }
                if (!(best <= eps_)) {
                    ++stats_.rejectedError;
                    park(u, v);
                    return;
                }
                owners.emplace_back(o, arg);
            }
        // And the new vertex within maxError of the original triangles around what it replaces (those of
        // u, v and the owned vertices); the new triangles' centres and edge midpoints too, to the same
        // original triangles or those around the new triangle's other vertices. The grid of original
        // triangles hands over only the few within maxError of each point.
        {
            ++mark_;
            auto allow = [&](std::uint32_t o) {
                for (std::uint32_t t : origTris_[o]) local_[t] = mark_;
            };
            allow(u);
            allow(v);
            for (const auto& [o, f] : owners) allow(o);
            if (!nearOriginal(p, [&](std::uint32_t t) { return local_[t] == mark_; })) {
                ++stats_.rejectedError;
                park(u, v);
                return;
            }
            for (const auto& tr : fresh) {
                ++markOwn_;
                for (int k = 0; k < 3; ++k)
                    if (tr[k] != u)
                        for (std::uint32_t t : origTris_[tr[k]]) own_[t] = markOwn_;
                const dvec3 a = at(tr.x), b = at(tr.y), c = at(tr.z);
                for (const dvec3& q : {(a + b + c) / 3.0, 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a)})
                    if (!nearOriginal(q, [&](std::uint32_t t) { return local_[t] == mark_ || own_[t] == markOwn_; })) {
                        ++stats_.rejectedError;
                        park(u, v);
                        return;
                    }
            }
        }
        // No crossing: each new triangle against the other new ones and the live triangles near it (exact
        // predicates). The octree is asked once, for the box of them all.
        dvec3 zoneLo = p, zoneHi = p;
        for (const auto& tr : fresh)
            for (int k = 0; k < 3; ++k) {
                zoneLo = glm::min(zoneLo, at(tr[k]));
                zoneHi = glm::max(zoneHi, at(tr[k]));
            }
        nearby_.clear();
        octree_->query(zoneLo - pad_, zoneHi + pad_, [&](std::uint32_t t) {
            if (std::find(ring.begin(), ring.end(), t) == ring.end()) {
                const glm::uvec3& b = T_[t];
                Nearby n{t, {}, {}, {glm::vec3(P_[b.x]), glm::vec3(P_[b.y]), glm::vec3(P_[b.z])}};
                bbox({P_[b.x], P_[b.y], P_[b.z]}, n.lo, n.hi);
                nearby_.push_back(n);
            }
            return false;
        });
        for (std::size_t f = 0; f < fresh.size(); ++f) {
            const glm::uvec3& a = fresh[f];
            const std::array<glm::vec3, 3> pa{glm::vec3(at(a.x)), glm::vec3(at(a.y)), glm::vec3(at(a.z))};
            bool clash = false;
            for (std::size_t g = f + 1; g < fresh.size() && !clash; ++g) {
                const glm::uvec3& b = fresh[g];
                clash = trianglesIntersect(
                    pa, {a.x, a.y, a.z}, {glm::vec3(at(b.x)), glm::vec3(at(b.y)), glm::vec3(at(b.z))}, {b.x, b.y, b.z});
            }
            dvec3 lo, hi;
            bbox({at(a.x), at(a.y), at(a.z)}, lo, hi);
            lo -= pad_;
            hi += pad_;
            for (std::size_t k = 0; k < nearby_.size() && !clash; ++k) {
                const Nearby& n = nearby_[k];
                if (n.lo.x > hi.x || n.lo.y > hi.y || n.lo.z > hi.z || n.hi.x < lo.x || n.hi.y < lo.y || n.hi.z < lo.z)
                    continue;
                const glm::uvec3& b = T_[n.t];
                clash = trianglesIntersect(pa, {a.x, a.y, a.z}, n.corners, {b.x, b.y, b.z});
            }
            if (clash) {
                ++stats_.rejectedCrossing;
                park(u, v);
                return;
            }
        }
        // Commit.
        for (std::uint32_t t : ring) {
            alive_[t] = 0;
            octree_->remove(t);
        }
        P_[u] = p;
        vertexAlive_[v] = 0;
        Q_[u] += Q_[v];
        const auto first = static_cast<std::uint32_t>(T_.size());
        for (const auto& tr : fresh) {
            const auto t = static_cast<std::uint32_t>(T_.size());
            T_.push_back(tr);
            alive_.push_back(1);
            owned_.emplace_back();
            for (int k = 0; k < 3; ++k) vt_[tr[k]].push_back(t);
            insert(t);
        }
        for (const auto& [o, f] : owners) owned_[first + f].push_back(o);
        for (std::uint32_t t : ring) owned_[t].clear();
        ++stats_.collapses;
        // Only u's quadric and position changed: its edges get new costs. The edges around its
        // neighbours keep theirs but are offered again, since a collapse refused there (the link
        // condition, a turn, a crossing) may pass now.
        ++stamp_[u];
        neighbours(u, scratch_.nu);
        for (std::uint32_t w : scratch_.nu) {
            push(std::min(u, w), std::max(u, w));
            if (parkedAt_[w] == 0) continue;  // no refused edge waits around w
            neighbours(w, scratch_.nv);
            for (std::uint32_t x : scratch_.nv) {
                if (x == u) continue;
                auto it = parked_.find(edgeKey(w, x));
                if (it == parked_.end()) continue;
                // Each edge is offered again a few times at most: a refusal for the distance bound
                // rarely turns (most of the attempts were such retries), and each costs a full test.
                if (++retries_[*it] > kMaxRetries) continue;
                parked_.erase(it);
                --parkedAt_[w];
                --parkedAt_[x];
                push(std::min(w, x), std::max(w, x));
            }
        }
    }
    static std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b) {
        return (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
    }
    /// A refused collapse waits until a collapse next to it changes its surroundings.
    void park(std::uint32_t a, std::uint32_t b) {
        if (!parked_.insert(edgeKey(a, b)).second) return;
        ++parkedAt_[a];
        ++parkedAt_[b];
    }
    void finish() {
        std::vector<std::int64_t> remap(P_.size(), -1);
        TriMesh out;
        const bool normals = m_.normals.size() == P_.size(), colors = m_.colors.size() == P_.size();
        for (std::uint32_t t = 0; t < T_.size(); ++t) {
            if (!alive_[t]) continue;
            glm::uvec3 tr = T_[t];
            for (int k = 0; k < 3; ++k) {
                if (remap[tr[k]] < 0) {
                    remap[tr[k]] = std::int64_t(out.positions.size());
                    out.positions.emplace_back(P_[tr[k]]);
                    if (normals) out.normals.push_back(m_.normals[tr[k]]);
                    if (colors) out.colors.push_back(m_.colors[tr[k]]);
                }
                tr[k] = static_cast<unsigned>(remap[tr[k]]);
            }
            out.triangles.push_back(tr);
        }
        m_ = std::move(out);
    }

    TriMesh& m_;
    double eps_;
    std::vector<dvec3> P_, O_;
    std::vector<glm::uvec3> T_, origT_;
    std::vector<char> alive_, vertexAlive_;
    std::vector<std::vector<std::uint32_t>> vt_, origTris_, owned_;
    std::vector<Quadric> Q_;
    std::vector<std::uint32_t> stamp_;
    std::optional<LooseOctree> octree_;  // the live triangles, by their boxes
    double pad_ = 0;                     // added to boxes asked of the octree
    struct Nearby {                      // a live triangle near a collapse
        std::uint32_t t;
        dvec3 lo, hi;
        std::array<glm::vec3, 3> corners;
    };
    std::vector<Nearby> nearby_;
    struct Scratch {  // a collapse's lists, kept between collapses so that none allocates
        std::vector<std::uint32_t> nu, nv, common, ring, edgeTris;
        std::vector<std::pair<double, dvec3>> options;
        std::vector<glm::uvec3> fresh;
        std::vector<std::pair<std::uint32_t, std::size_t>> owners;
        std::vector<std::size_t> successor;
    } scratch_;
    std::unordered_map<std::int64_t, std::vector<std::uint32_t>> origGrid_;  // cell -> original triangles
    std::vector<std::uint32_t> local_, own_;  // original triangle -> mark_ / markOwn_ when a test may use it
    std::uint32_t mark_ = 0, markOwn_ = 0;
    double cell_ = 1.0;
    std::priority_queue<Candidate> heap_;
    std::unordered_set<std::uint64_t> parked_;
    std::vector<std::uint32_t> parkedAt_;                      // vertex -> parked edges at it
    std::unordered_map<std::uint64_t, std::uint8_t> retries_;  // edge -> times offered again
    SimplifyStats stats_;
};

}  // namespace

SimplifyStats simplify(TriMesh& mesh, double maxError) {
    if (mesh.triangles.empty() || !(maxError > 0)) return {};
    Simplifier s(mesh, maxError);
    return s.run();
}

}  // namespace isoforge::mesh
