/// @file Polyhedra as exact signed distance fields. Distance: closest triangle through a bounding
/// volume hierarchy (O(log n) per point). Sign: for a closed, edge-manifold mesh, the angle-weighted
/// pseudonormal of the closest feature (Baerentzen and Aanaes 2005), after making the orientation
/// consistent and outward; otherwise the winding number of the mesh closed by caps (a ray's signed
/// crossings, csg/ray_winding.h, or where no ray passes clear, the generalized winding number).

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <queue>
#include <span>
#include <stdexcept>
#include <unordered_map>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "core/fast_atan2.h"
#include "csg/ray_winding.h"
#include "csg/shapes.h"
#include "mesh/self_intersections.h"
#include "mesh/triangulate.h"

namespace isoforge::csg {

using implicit::Box3;
using implicit::Interval;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

/// Which feature of a triangle holds the closest point.
enum Feature : std::uint8_t { kFace, kVertA, kVertB, kVertC, kEdgeAB, kEdgeBC, kEdgeCA };

struct Closest {
    float d2;
    Feature feature;
    glm::vec3 point;
};

/// Closest point on triangle abc to p, by Voronoi regions (Ericson, Real-Time Collision Detection 5.1.5).
Closest closestOnTriangle(const glm::vec3& p, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
    auto at = [&](const glm::vec3& q, Feature f) { return Closest{glm::dot(p - q, p - q), f, q}; };
    const glm::vec3 ab = b - a, ac = c - a, ap = p - a;
    const float d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return at(a, kVertA);
    const glm::vec3 bp = p - b;
    const float d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return at(b, kVertB);
    const float vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return at(a + ab * (d1 / (d1 - d3)), kEdgeAB);
    const glm::vec3 cp = p - c;
    const float d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return at(c, kVertC);
    const float vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return at(a + ac * (d2 / (d2 - d6)), kEdgeCA);
    const float va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
        return at(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))), kEdgeBC);
    const float denom = 1.f / (va + vb + vc);
    return at(a + ab * (vb * denom) + ac * (vc * denom), kFace);
}

/// Solid angle of triangle abc seen from the origin (van Oosterom and Strackee).
double solidAngle(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    const double la = glm::length(a), lb = glm::length(b), lc = glm::length(c);
    const double num = glm::dot(a, glm::cross(b, c));
    // A point in the triangle's plane sees no solid angle. Rounding makes num and den both tiny for a
    // point on one of its edges, where atan2 would return anything up to +-pi: a grid sample on the
    // bottom edge of a mesh then counted as inside, and marching cubes made a blob around it.
    if (std::abs(num) <= 1e-12 * la * lb * lc) return 0.0;
    const double den = la * lb * lc + glm::dot(a, b) * lc + glm::dot(b, c) * la + glm::dot(c, a) * lb;
    // The polynomial atan2: its error (3.5e-6 rad a triangle) is far from moving a sum of 0 or 4 pi
    // across the 2 pi threshold, and glibc's atan2 took a third of the time of an open imported mesh.
    return 2.0 * fastAtan2(num, den);
}

/// Inlined by force: GCC kept it a call, 16% of example020's samples; inlined, the command takes 9% fewer
/// instructions (callgrind, --resolution 128).
[[gnu::always_inline]] inline float boxDistance2(const glm::vec3& p, const glm::vec3& lo, const glm::vec3& hi) {
    const glm::vec3 d = glm::max(glm::max(lo - p, p - hi), glm::vec3(0.f));
    return glm::dot(d, d);
}

std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b) {
    return (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
}

class Polyhedron final : public implicit::Field {
public:
    Polyhedron(std::vector<glm::vec3> pts, std::vector<glm::uvec3> tris, std::string what, bool trusted)
        : p_(std::move(pts)), t_(std::move(tris)), what_(std::move(what)) {
        for (const auto& t : t_)
            for (int k = 0; k < 3; ++k) box_ = box_.unite(Box3{p_[t[k]], p_[t[k]]});
        closed_ = orient();
        if (!closed_) capBoundary();
        buildBvh();
        // A closed mesh signs by pseudonormals when it cannot fold through itself: generated, or
        // checked free of self-intersections (exact predicates), which costs far less than the
        // winding number at every sample near the surface.
        // A user's mesh signs by its face normal only where the closest point is inside a face;
        // nearer an edge or a vertex (the tips of thin spikes, where float rounding picks the
        // feature) by the winding number, as before.
        pseudonormals_ = closed_ && (trusted || selfIntersectionFree());
        facesOnly_ = pseudonormals_ && !trusted;
        const float size = glm::length(box_.size());
        onSurface2_ = (1e-5f * size) * (1e-5f * size);
        if (pseudonormals_) buildPseudonormals();
        if (!pseudonormals_ || facesOnly_) buildDipoles();
    }

    bool closed() const { return closed_; }
    bool selfIntersectionFree() const {
        mesh::TriMesh m;
        m.positions = p_;
        m.triangles = t_;
        return mesh::selfIntersections(m, 1).pairs == 0;
    }
    float value(const glm::vec3& q) const override {
        const auto [c, tri] = closest(q);
        return signedDistance(inside(q, c, tri), std::sqrt(c.d2));
    }
    /// Batches (an 8^3 block at a time when sampling): distances per point; where the sign comes from
    /// the winding number, a point inside the surface-free ball of an earlier point of the batch
    /// (|p - q| < d(q)) takes that point's sign, since the winding number of a closed chain of
    /// triangles (open meshes are capped first) is constant off the surface. Only points near the
    /// surface pay for the winding number.
    /// The closest triangle of each point comes from the few triangles that can be closest to any
    /// point of the batch's box (one traversal of the hierarchy per batch, not per point).
    void values(std::span<const glm::vec3> p, std::span<float> out) const override {
        if (p.empty()) return;
        std::vector<Hit> hit(p.size());
        std::vector<std::uint32_t> idx(p.size());
        std::iota(idx.begin(), idx.end(), 0u);
        closestInBatch(p, idx, hit);
        if (pseudonormals_ && !facesOnly_) {
            for (std::size_t i = 0; i < p.size(); ++i) {
                const auto& [c, tri] = hit[i];
                out[i] = signedDistance(inside(p[i], c, tri), std::sqrt(c.d2));
            }
            return;
        }
        std::vector<bool> in(p.size());
        for (std::size_t i = 0; i < p.size(); ++i) {
            const auto& [c, tri] = hit[i];
            const float d = std::sqrt(c.d2);
            // Earlier points of the batch that are likely neighbours: the previous one along each axis
            // of an 8^3 block, and the last one.
            int known = -1;
            for (std::size_t back : {std::size_t(1), std::size_t(8), std::size_t(64)}) {
                if (i < back) break;
                const std::size_t j = i - back;
                const float dj = std::abs(out[j]);
                if (glm::length(p[i] - p[j]) < 0.999f * dj) {
                    known = static_cast<int>(j);
                    break;
                }
            }
            in[i] = known >= 0 ? bool(in[std::size_t(known)]) : inside(p[i], c, tri);
            out[i] = signedDistance(in[i], d);
        }
    }
    Interval bound(const Box3& b) const override {
        // 1-Lipschitz; far from the polyhedron, the distance to its box is a cheaper lower bound.
        const glm::vec3 c = b.centre();
        const float toBox = std::sqrt(boxDistance2(c, box_.min, box_.max)) - b.halfDiagonal();
        if (toBox > 0) return {toBox, kInf};
        return implicit::lipschitz(value(c), 1.f, b.halfDiagonal());
    }
    Box3 bounds() const override { return box_; }
    glm::vec3 gradient(const glm::vec3& q) const override {
        // Not a structured binding: clang 14 refuses to capture one in a lambda.
        const auto hit = closest(q);
        return gradientFrom(q, hit.first, hit.second, [&] { return inside(q, hit.first, hit.second); });
    }
    /// One closest-triangle search for both.
    float valueAndGradient(const glm::vec3& q, glm::vec3& g) const override {
        const auto [c, tri] = closest(q);
        const bool in = inside(q, c, tri);
        g = gradientFrom(q, c, tri, [in] { return in; });
        return signedDistance(in, std::sqrt(c.d2));
    }
    bool cheapGradient() const override { return true; }
    std::string describe() const override {
        return what_ + "(" + std::to_string(t_.size()) + " triangles" + (closed_ ? ")" : ", open)");
    }

private:
    /// A batch searches among at most this many candidate triangles (beyond, it is cut in two, down to
    /// kSplitPoints points, then each point searches the hierarchy). 256 rather than 128: at 256 voxels,
    /// example010 takes 8% and example020 2% fewer instructions, the same bytes; 512 gains nothing more.
    static constexpr std::size_t kMaxCandidates = 256;
    static constexpr std::size_t kSplitPoints = 32;
    using Hit = std::pair<Closest, std::uint32_t>;
    using Node = MeshBvhNode;

    void buildBvh() {
        order_.resize(t_.size());
        std::iota(order_.begin(), order_.end(), 0u);
        std::vector<glm::vec3> centroid(t_.size());
        for (std::size_t i = 0; i < t_.size(); ++i) centroid[i] = (p_[t_[i].x] + p_[t_[i].y] + p_[t_[i].z]) / 3.f;
        nodes_.reserve(2 * t_.size() / kLeafSize + 2);
        nodes_.push_back({});
        struct Item {
            std::uint32_t node, begin, end;
        };
        std::vector<Item> stack{{0, 0, static_cast<std::uint32_t>(t_.size())}};
        while (!stack.empty()) {
            const Item it = stack.back();
            stack.pop_back();
            glm::vec3 lo(kInf), hi(-kInf), clo(kInf), chi(-kInf);
            for (std::uint32_t i = it.begin; i < it.end; ++i) {
                const glm::uvec3& t = t_[order_[i]];
                for (int k = 0; k < 3; ++k) {
                    lo = glm::min(lo, p_[t[k]]);
                    hi = glm::max(hi, p_[t[k]]);
                }
                clo = glm::min(clo, centroid[order_[i]]);
                chi = glm::max(chi, centroid[order_[i]]);
            }
            nodes_[it.node].lo = lo;
            nodes_[it.node].hi = hi;
            const glm::vec3 ext = chi - clo;
            const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
            if (it.end - it.begin <= kLeafSize || ext[axis] <= 0.f) {
                nodes_[it.node].first = it.begin;
                nodes_[it.node].count = it.end - it.begin;
                continue;
            }
            const std::uint32_t mid = it.begin + (it.end - it.begin) / 2;
            std::nth_element(order_.begin() + it.begin, order_.begin() + mid, order_.begin() + it.end,
                             [&](std::uint32_t a, std::uint32_t b) {
                                 return centroid[a][axis] < centroid[b][axis] ||
                                        (centroid[a][axis] == centroid[b][axis] && a < b);
                             });
            const auto left = static_cast<std::uint32_t>(nodes_.size());
            nodes_.push_back({});
            nodes_.push_back({});
            nodes_[it.node].first = left;
            nodes_[it.node].count = 0;
            stack.push_back({left, it.begin, mid});
            stack.push_back({left + 1, mid, it.end});
        }
    }

    Hit closest(const glm::vec3& q) const {
        Closest best{kInf, kFace, glm::vec3(0.f)};
        std::uint32_t bestTri = 0;
        std::uint32_t stack[64];
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const Node& n = nodes_[stack[--top]];
            if (boxDistance2(q, n.lo, n.hi) >= best.d2) continue;
            if (n.count > 0) {
                for (std::uint32_t i = n.first; i < n.first + n.count; ++i) {
                    const glm::uvec3& t = t_[order_[i]];
                    const Closest c = closestOnTriangle(q, p_[t.x], p_[t.y], p_[t.z]);
                    if (c.d2 < best.d2 || (c.d2 == best.d2 && order_[i] < bestTri)) {
                        best = c;
                        bestTri = order_[i];
                    }
                }
                continue;
            }
            // Visit the nearer child first.
            const float dl = boxDistance2(q, nodes_[n.first].lo, nodes_[n.first].hi);
            const float dr = boxDistance2(q, nodes_[n.first + 1].lo, nodes_[n.first + 1].hi);
            if (dl <= dr) {
                stack[top++] = n.first + 1;
                stack[top++] = n.first;
            } else {
                stack[top++] = n.first;
                stack[top++] = n.first + 1;
            }
        }
        return {best, bestTri};
    }

    /// The closest triangle of each point p[i], i in idx, from the candidates of the points' box; a
    /// box with too many candidates to search among (and many points) is cut in two across its longest
    /// side first, since the candidates of a smaller box are fewer (the result does not depend on the cuts).
    void closestInBatch(std::span<const glm::vec3> p, std::span<std::uint32_t> idx, std::span<Hit> hit) const {
        glm::vec3 lo(kInf), hi(-kInf);
        for (const std::uint32_t i : idx) lo = glm::min(lo, p[i]), hi = glm::max(hi, p[i]);
        const Candidates near = candidates(lo, hi);
        const bool few = near.tri.size() <= kMaxCandidates;
        if (!few && idx.size() > kSplitPoints) {
            const glm::vec3 ext = hi - lo;
            const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
            const float mid = 0.5f * (lo[axis] + hi[axis]);
            const auto cut = std::partition(idx.begin(), idx.end(), [&](std::uint32_t i) { return p[i][axis] < mid; });
            if (cut != idx.begin() && cut != idx.end()) {
                const auto n = static_cast<std::size_t>(cut - idx.begin());
                closestInBatch(p, idx.first(n), hit);
                closestInBatch(p, idx.subspan(n), hit);
                return;
            }
        }
        for (const std::uint32_t i : idx) hit[i] = few ? closestAmong(p[i], near) : closest(p[i]);
    }

    /// Triangles that can hold the closest point of some point of the box [lo, hi]: those within
    /// d(centre) + half the diagonal of it, which bounds every point's distance, nearest to the centre
    /// first, with their boxes; at most kMaxCandidates + 1 are collected (more: the caller searches
    /// point by point).
    struct Candidates {
        std::vector<std::uint32_t> tri;
        std::vector<glm::vec3> lo, hi;
        std::vector<float> gap2;  ///< squared distance from the batch's box to the triangle's, ascending
    };
    Candidates candidates(const glm::vec3& lo, const glm::vec3& hi) const {
        const glm::vec3 centre = 0.5f * (lo + hi);
        const float reach = std::sqrt(closest(centre).first.d2) + 0.5f * glm::length(hi - lo);
        const float reach2 = reach * reach * (1.f + 1e-5f) + 1e-30f;
        struct Found {
            float gap2, centre2;  // to the batch's box, to its centre
            std::uint32_t tri;
            bool operator<(const Found& o) const {
                return gap2 != o.gap2 ? gap2 < o.gap2 : (centre2 != o.centre2 ? centre2 < o.centre2 : tri < o.tri);
            }
        };
        std::vector<Found> found;
        std::uint32_t stack[64];
        int top = 0;
        stack[top++] = 0;
        while (top > 0 && found.size() <= kMaxCandidates) {
            const Node& n = nodes_[stack[--top]];
            const glm::vec3 gap = glm::max(glm::max(n.lo - hi, lo - n.hi), glm::vec3(0.f));
            if (glm::dot(gap, gap) > reach2) continue;
            if (n.count > 0) {
                for (std::uint32_t i = n.first; i < n.first + n.count; ++i) {
                    const glm::uvec3& t = t_[order_[i]];
                    const glm::vec3 tlo = glm::min(glm::min(p_[t.x], p_[t.y]), p_[t.z]);
                    const glm::vec3 thi = glm::max(glm::max(p_[t.x], p_[t.y]), p_[t.z]);
                    const glm::vec3 g = glm::max(glm::max(tlo - hi, lo - thi), glm::vec3(0.f));
                    found.push_back({glm::dot(g, g), boxDistance2(centre, tlo, thi), order_[i]});
                }
                continue;
            }
            stack[top++] = n.first;
            stack[top++] = n.first + 1;
        }
        std::sort(found.begin(), found.end());
        Candidates c;
        for (const Found& f : found) {
            const glm::uvec3& t = t_[f.tri];
            c.tri.push_back(f.tri);
            c.gap2.push_back(f.gap2);
            c.lo.push_back(glm::min(glm::min(p_[t.x], p_[t.y]), p_[t.z]));
            c.hi.push_back(glm::max(glm::max(p_[t.x], p_[t.y]), p_[t.z]));
        }
        return c;
    }
    /// closest() over the candidates: the nearest, the lowest index among equals (a triangle whose
    /// box is farther than the best so far cannot be nearer, nor can any after the first whose box is
    /// farther from the batch's box).
    Hit closestAmong(const glm::vec3& q, const Candidates& c) const {
        Closest best{kInf, kFace, glm::vec3(0.f)};
        std::uint32_t bestTri = 0;
        for (std::size_t k = 0; k < c.tri.size(); ++k) {
            if (c.gap2[k] > best.d2) break;
            if (boxDistance2(q, c.lo[k], c.hi[k]) > best.d2) continue;
            const glm::uvec3& t = t_[c.tri[k]];
            const Closest r = closestOnTriangle(q, p_[t.x], p_[t.y], p_[t.z]);
            if (r.d2 < best.d2 || (r.d2 == best.d2 && c.tri[k] < bestTri)) {
                best = r;
                bestTri = c.tri[k];
            }
        }
        return {best, bestTri};
    }

    /// The gradient at q from its closest point: away from the surface, the unit vector from it (away
    /// from the inside, which `in()` tells, asked only there); on it, the face's normal (central
    /// differences for a mesh signed by its winding number).
    template <class Inside>
    glm::vec3 gradientFrom(const glm::vec3& q, const Closest& c, std::uint32_t tri, Inside in) const {
        const glm::vec3 d = q - c.point;
        const float len = glm::length(d);
        if (len > 1e-6f * (1.f + glm::length(box_.size()))) return (in() ? -1.f : 1.f) * d / len;
        return pseudonormals_ ? faceNormal_[tri] : windingGradient(q, tri);  // on the surface
    }
    /// On the surface of a mesh signed by its winding number: the closest face's normal, pointing from the
    /// side the winding number counts inside to the side it counts outside, one step of the central
    /// differences (Field::gradient) away on each side. Two winding numbers instead of six closest-triangle
    /// searches and winding numbers; where both sides agree (an open edge, a face inside the solid), the
    /// central differences.
    glm::vec3 windingGradient(const glm::vec3& q, std::uint32_t tri) const {
        const glm::uvec3& t = t_[tri];
        const glm::vec3 a = glm::cross(p_[t.y] - p_[t.x], p_[t.z] - p_[t.x]);
        const float area2 = glm::length(a);
        if (!(area2 > 0.f)) return Field::gradient(q);
        const glm::vec3 n = a / area2;
        const float h = std::max(1e-4f, 1e-4f * glm::length(q));
        const bool front = windingNumberInside(q + h * n), back = windingNumberInside(q - h * n);
        if (front == back) return Field::gradient(q);
        return front ? -n : n;
    }
    /// A point on the surface that is inside (see inside()) is the least negative normal float, not -0: marching
    /// cubes counts 0 as outside, and the value stays negative through scales and transforms.
    static float signedDistance(bool in, float d) { return in ? -std::max(d, std::numeric_limits<float>::min()) : d; }
    bool inside(const glm::vec3& q, const Closest& c, std::uint32_t tri) const {
        // On the surface within the rounding of the point's coordinates (a grid sample on OpenSCAD's integer corner,
        // edge or face): inside, the solid being closed, so that an apex or an edge on a sample is not cut a voxel
        // short. The band is a few units in the last place, far inside the sharpening's probes (a thousandth of a
        // voxel for points under two thousand voxels from the origin), so the gradient near the surface stays true.
        const float ulps =
            4.f * std::numeric_limits<float>::epsilon() * std::max({std::abs(q.x), std::abs(q.y), std::abs(q.z)});
        if (c.d2 <= ulps * ulps) return true;
        // Near the surface (grid samples on a face lying in a grid plane): as the winding number signs them, so that
        // a part thinner than a voxel keeps the samples on its faces.
        if (facesOnly_ && (c.feature != kFace || c.d2 <= onSurface2_)) return windingNumberInside(q);
        if (pseudonormals_) {
            const glm::uvec3& t = t_[tri];
            glm::vec3 n;
            switch (c.feature) {
                case kFace:
                    n = faceNormal_[tri];
                    break;
                case kVertA:
                    n = vertexNormal_[t.x];
                    break;
                case kVertB:
                    n = vertexNormal_[t.y];
                    break;
                case kVertC:
                    n = vertexNormal_[t.z];
                    break;
                case kEdgeAB:
                    n = edgeNormal_.at(edgeKey(t.x, t.y));
                    break;
                case kEdgeBC:
                    n = edgeNormal_.at(edgeKey(t.y, t.z));
                    break;
                default:
                    n = edgeNormal_.at(edgeKey(t.z, t.x));
                    break;
            }
            const bool pinched = (c.feature == kVertA && pinched_[t.x]) || (c.feature == kVertB && pinched_[t.y]) ||
                                 (c.feature == kVertC && pinched_[t.z]);
            if (!pinched) return glm::dot(q - c.point, n) < 0.f;
            return exactWindingInside(q);
        }
        return windingNumberInside(q);
    }
    bool exactWindingInside(const glm::vec3& q) const {
        double winding = 0;
        for (const auto& t : t_)
            winding += solidAngle(glm::dvec3(p_[t.x] - q), glm::dvec3(p_[t.y] - q), glm::dvec3(p_[t.z] - q));
        return std::abs(winding) > 2.0 * M_PI;
    }
    /// |Winding number| >= 1. The chain of triangles is closed (capBoundary), so the winding number is the
    /// signed count of a ray's crossings wherever the ray passes clear of edges, vertices and planes: a
    /// few nodes and triangles (csg/ray_winding.h) instead of the solid angle of every triangle near q.
    /// Where three rays are refused, by the solid angles.
    bool windingNumberInside(const glm::vec3& q) const {
        if (const auto in = insideByRays({nodes_, order_, t_, p_}, q)) return *in;
        return solidAngleInside(q);
    }
    /// Generalized winding number > 1/2, hierarchically (Barill et al. 2018, first order): a node
    /// far from q (distance > 2 radii) counts as the dipole of its area-weighted normals; near
    /// nodes are opened, leaves summed exactly (van Oosterom and Strackee).
    bool solidAngleInside(const glm::vec3& q) const {
        double omega = 0;
        std::uint32_t stack[64];
        int top = 0;
        stack[top++] = 0;
        const glm::dvec3 qd(q);
        while (top > 0) {
            const std::uint32_t ni = stack[--top];
            const Node& n = nodes_[ni];
            const Dipole& dp = dipole_[ni];
            const glm::dvec3 d = dp.centre - qd;
            const double dist2 = glm::dot(d, d);
            if (dist2 > 4.0 * dp.radius2) {
                omega += glm::dot(dp.normal, d) / (dist2 * std::sqrt(dist2));
                continue;
            }
            if (n.count > 0) {
                for (std::uint32_t i = n.first; i < n.first + n.count; ++i) {
                    const glm::uvec3& t = t_[order_[i]];
                    omega += solidAngle(glm::dvec3(p_[t.x]) - qd, glm::dvec3(p_[t.y]) - qd, glm::dvec3(p_[t.z]) - qd);
                }
                continue;
            }
            stack[top++] = n.first;
            stack[top++] = n.first + 1;
        }
        // |winding number| = |omega| / 4 pi > 1/2: either orientation, as OpenSCAD takes faces listed
        // either way round (its convention is clockwise seen from outside); an open or non-manifold
        // mesh (two solids touching along an edge) is never re-oriented, so the sign must not matter.
        return std::abs(omega) > 2.0 * M_PI;
    }

    void buildDipoles() {
        dipole_.assign(nodes_.size(), Dipole{});
        // Children come after their parent in nodes_, so one backward sweep fills every node.
        for (std::size_t k = nodes_.size(); k-- > 0;) {
            const Node& n = nodes_[k];
            Dipole& d = dipole_[k];
            double area = 0;
            glm::dvec3 weighted(0.0);
            if (n.count > 0) {
                for (std::uint32_t i = n.first; i < n.first + n.count; ++i) {
                    const glm::uvec3& t = t_[order_[i]];
                    const glm::dvec3 a(p_[t.x]), b(p_[t.y]), c(p_[t.z]);
                    const glm::dvec3 an = 0.5 * glm::cross(b - a, c - a);
                    const double ar = glm::length(an);
                    d.normal += an;
                    weighted += ar * (a + b + c) / 3.0;
                    area += ar;
                }
            } else {
                for (std::uint32_t c = n.first; c <= n.first + 1; ++c) {
                    d.normal += dipole_[c].normal;
                    weighted += dipole_[c].area * dipole_[c].centre;
                    area += dipole_[c].area;
                }
            }
            d.area = area;
            d.centre = area > 0 ? weighted / area : 0.5 * (glm::dvec3(n.lo) + glm::dvec3(n.hi));
            for (int c = 0; c < 8; ++c) {
                const glm::dvec3 corner(c & 1 ? n.hi.x : n.lo.x, c & 2 ? n.hi.y : n.lo.y, c & 4 ? n.hi.z : n.lo.z);
                d.radius2 = std::max(d.radius2, glm::dot(corner - d.centre, corner - d.centre));
            }
        }
    }

    /// Makes the orientation consistent (per connected component, breadth first over shared edges)
    /// and outward (a component of negative signed volume that is not nested in another is flipped;
    /// a consistently oriented input keeps its nesting). False when the mesh is not closed and
    /// edge-manifold: then the sign comes from the winding number.
    bool orient() {
        std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> edgeFaces;
        edgeFaces.reserve(t_.size() * 3 / 2);
        for (std::uint32_t f = 0; f < t_.size(); ++f)
            for (int k = 0; k < 3; ++k) edgeFaces[edgeKey(t_[f][k], t_[f][(k + 1) % 3])].push_back(f);
        bool consistent = true;
        for (const auto& [key, faces] : edgeFaces) {
            if (faces.size() != 2) return false;
            if (sameDirection(faces[0], faces[1], key)) consistent = false;
        }
        if (!consistent) {
            std::vector<int> state(t_.size(), -1);  // component index once visited
            for (std::uint32_t seed = 0; seed < t_.size(); ++seed) {
                if (state[seed] >= 0) continue;
                std::vector<std::uint32_t> comp{seed};
                state[seed] = 1;
                for (std::size_t i = 0; i < comp.size(); ++i) {
                    const std::uint32_t f = comp[i];
                    for (int k = 0; k < 3; ++k) {
                        const std::uint64_t key = edgeKey(t_[f][k], t_[f][(k + 1) % 3]);
                        const auto& fs = edgeFaces[key];
                        const std::uint32_t g = fs[0] == f ? fs[1] : fs[0];
                        if (state[g] >= 0) {
                            if (sameDirection(f, g, key)) return false;  // non-orientable
                            continue;
                        }
                        if (sameDirection(f, g, key)) std::swap(t_[g].y, t_[g].z);
                        state[g] = 1;
                        comp.push_back(g);
                    }
                }
                double vol = 0;
                for (std::uint32_t f : comp)
                    vol +=
                        glm::dot(glm::dvec3(p_[t_[f].x]), glm::cross(glm::dvec3(p_[t_[f].y]), glm::dvec3(p_[t_[f].z])));
                if (vol < 0)
                    for (std::uint32_t f : comp) std::swap(t_[f].y, t_[f].z);
            }
        } else {
            double vol = 0;
            for (const auto& t : t_)
                vol += glm::dot(glm::dvec3(p_[t.x]), glm::cross(glm::dvec3(p_[t.y]), glm::dvec3(p_[t.z])));
            if (vol < 0)
                for (auto& t : t_) std::swap(t.y, t.z);
        }
        return true;
    }
    /// Closes an open or inconsistently oriented mesh for the winding number. Its boundary (each
    /// directed edge counted +1, its reverse -1) is a cycle; coning it to one point per connected
    /// piece (the piece's centroid) adds triangles whose boundary cancels it. The winding number of
    /// the result is then a multiple of 4 pi off the triangles, so the sign changes only across the
    /// surface and the zero set is closed. (Left open, the generalized winding number crosses 2 pi
    /// away from the surface, where the field would jump from +d to -d with no zero between: an
    /// open mesh out of the mesher, as OpenSCAD's issue 964 gave.) Small holes get small caps.
    void capBoundary() {
        std::map<std::pair<std::uint32_t, std::uint32_t>, int> net;  // ordered: deterministic caps
        for (const auto& t : t_)
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t a = t[k], b = t[(k + 1) % 3];
                net[{std::min(a, b), std::max(a, b)}] += a < b ? 1 : -1;
            }
        std::vector<std::uint32_t> parent(p_.size());
        std::iota(parent.begin(), parent.end(), 0u);
        auto find = [&](std::uint32_t a) {
            while (parent[a] != a) a = parent[a] = parent[parent[a]];
            return a;
        };
        for (const auto& [e, n] : net)
            if (n != 0) parent[find(e.first)] = find(e.second);
        std::map<std::uint32_t, std::pair<glm::dvec3, int>> pieces;  // root -> sum of its points, count
        std::vector<bool> counted(p_.size());
        for (const auto& [e, n] : net)
            if (n != 0)
                for (std::uint32_t v : {e.first, e.second})
                    if (!counted[v]) {
                        counted[v] = true;
                        auto& piece = pieces[find(v)];
                        piece.first += glm::dvec3(p_[v]);
                        ++piece.second;
                    }
        std::map<std::uint32_t, std::uint32_t> apex;
        for (const auto& [root, piece] : pieces) {
            apex[root] = static_cast<std::uint32_t>(p_.size());
            p_.push_back(glm::vec3(piece.first / double(piece.second)));
        }
        for (const auto& [e, n] : net) {
            if (n == 0) continue;
            const std::uint32_t c = apex[find(e.first)];
            // net n > 0: the edge runs first -> second n times more than back; cancel with second -> first.
            const glm::uvec3 cap = n > 0 ? glm::uvec3(e.second, e.first, c) : glm::uvec3(e.first, e.second, c);
            if (!(glm::length(glm::cross(p_[cap.y] - p_[cap.x], p_[cap.z] - p_[cap.x])) > 0.f))
                continue;  // no solid angle anywhere off it
            for (int i = 0; i < std::abs(n); ++i) t_.push_back(cap);
        }
    }
    bool sameDirection(std::uint32_t f, std::uint32_t g, std::uint64_t key) const {
        auto dir = [&](std::uint32_t face) {
            for (int k = 0; k < 3; ++k)
                if (edgeKey(t_[face][k], t_[face][(k + 1) % 3]) == key) return t_[face][k] < t_[face][(k + 1) % 3];
            return false;
        };
        return dir(f) == dir(g);
    }

    void buildPseudonormals() {
        // A vertex where several fans of triangles meet (two solids touching at a point) has no
        // meaningful pseudonormal: queries closest to it use the winding number.
        std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> fans(p_.size());
        for (const auto& t : t_)
            for (int k = 0; k < 3; ++k) fans[t[k]].emplace_back(t[(k + 1) % 3], t[(k + 2) % 3]);
        pinched_.assign(p_.size(), false);
        for (std::size_t v = 0; v < p_.size(); ++v) {
            auto& fan = fans[v];
            if (fan.empty()) continue;
            std::sort(fan.begin(), fan.end());
            std::uint32_t at = fan.front().first;
            std::size_t steps = 0;
            do {
                auto it = std::lower_bound(fan.begin(), fan.end(), std::make_pair(at, std::uint32_t{0}));
                if (it == fan.end() || it->first != at) break;
                at = it->second;
                ++steps;
            } while (at != fan.front().first && steps <= fan.size());
            pinched_[v] = steps != fan.size() || at != fan.front().first;
        }

        faceNormal_.resize(t_.size());
        vertexNormal_.assign(p_.size(), glm::vec3(0.f));
        edgeNormal_.reserve(t_.size() * 3 / 2);
        for (std::uint32_t f = 0; f < t_.size(); ++f) {
            const glm::uvec3& t = t_[f];
            const glm::vec3 n = glm::normalize(glm::cross(p_[t.y] - p_[t.x], p_[t.z] - p_[t.x]));
            faceNormal_[f] = n;
            for (int k = 0; k < 3; ++k) {
                const glm::vec3 e1 = glm::normalize(p_[t[(k + 1) % 3]] - p_[t[k]]);
                const glm::vec3 e2 = glm::normalize(p_[t[(k + 2) % 3]] - p_[t[k]]);
                vertexNormal_[t[k]] += std::acos(glm::clamp(glm::dot(e1, e2), -1.f, 1.f)) * n;
                edgeNormal_[edgeKey(t[k], t[(k + 1) % 3])] += n;
            }
        }
    }

    static constexpr std::uint32_t kLeafSize = 4;
    std::vector<glm::vec3> p_;
    std::vector<glm::uvec3> t_;
    std::string what_;
    Box3 box_;
    std::vector<Node> nodes_;
    std::vector<std::uint32_t> order_;
    bool closed_ = false;
    std::vector<glm::vec3> faceNormal_, vertexNormal_;
    std::vector<bool> pinched_;
    struct Dipole {
        glm::dvec3 normal{0.0}, centre{0.0};
        double area = 0, radius2 = 0;
    };
    std::vector<Dipole> dipole_;
    bool pseudonormals_ = false;
    bool facesOnly_ = false;
    float onSurface2_ = 0.f;  ///< squared distances this small count as on the surface  ///< pseudonormals of faces
                              ///< only (a user's mesh): elsewhere the winding number
    std::unordered_map<std::uint64_t, glm::vec3> edgeNormal_;
};

}  // namespace

bool facesPairUp(const std::vector<glm::vec3>& points, const std::vector<std::vector<int>>& faces,
                 bool manifoldVertices) {
    // Points are compared by position, as OpenSCAD's CGAL conversion merges them.
    std::map<std::tuple<float, float, float>, int> ids;
    std::vector<int> id(points.size());
    for (std::size_t i = 0; i < points.size(); ++i)
        id[i] = ids.emplace(std::make_tuple(points[i].x, points[i].y, points[i].z), int(ids.size())).first->second;
    std::map<std::pair<int, int>, int> directed;
    std::vector<std::map<int, int>> fan(ids.size());  // at each point: next -> previous neighbour of a face
    for (const auto& face : faces) {
        std::vector<int> loop;
        for (int i : face)
            if (loop.empty() || id[i] != loop.back()) loop.push_back(id[i]);
        while (loop.size() > 1 && loop.front() == loop.back()) loop.pop_back();
        if (loop.size() < 3) continue;
        const std::size_t n = loop.size();
        for (std::size_t k = 0; k < n; ++k) {
            if (++directed[{loop[k], loop[(k + 1) % n]}] > 1) return false;
            fan[std::size_t(loop[k])][loop[(k + 1) % n]] = loop[(k + n - 1) % n];
        }
    }
    for (const auto& [edge, count] : directed)
        if (!directed.count({edge.second, edge.first})) return false;
    if (manifoldVertices)
        for (const auto& links : fan) {
            // One cycle through all the point's faces: from any neighbour, previous after previous.
            if (links.empty()) continue;
            std::size_t steps = 0;
            int at = links.begin()->first;
            do {
                auto it = links.find(at);
                if (it == links.end()) return false;
                at = it->second;
                ++steps;
            } while (at != links.begin()->first && steps <= links.size());
            if (steps != links.size()) return false;
        }
    return !directed.empty();
}

FieldPtr makePolyhedron(std::vector<glm::vec3> points, const std::vector<std::vector<int>>& faces) {
    if (faces.size() < 4) throw std::invalid_argument("polyhedron: a closed polyhedron needs at least 4 faces");
    for (std::size_t f = 0; f < faces.size(); ++f) {
        if (faces[f].size() < 3)
            throw std::invalid_argument("polyhedron: face " + std::to_string(f) + " has fewer than 3 points");
        for (int i : faces[f])
            if (i < 0 || static_cast<std::size_t>(i) >= points.size())
                throw std::invalid_argument("polyhedron: face " + std::to_string(f) + " names point " +
                                            std::to_string(i) + ", but there are " + std::to_string(points.size()));
    }
    // Concave and slightly non-planar faces are triangulated in their own plane. The sign comes from
    // the winding number, not pseudonormals: users' polyhedra may touch themselves or fold slightly
    // (a pentagon with a point on its own edge, in OpenSCAD's issue 1198, gave wrong signs and an
    // open mesh through pseudonormals).
    std::vector<glm::uvec3> tris;
    for (const auto& face : faces)
        for (const glm::uvec3& tri : mesh::triangulateFace(points, face)) tris.push_back(tri);
    return makeTriangleMeshField(std::move(points), std::move(tris), "polyhedron", nullptr, false);
}

FieldPtr makeTriangleMeshField(std::vector<glm::vec3> points, std::vector<glm::uvec3> triangles, std::string what,
                               bool* closed, bool trusted) {
    // Merge points at the same position (exports and STL files repeat them), then drop triangles
    // of zero area: the remaining edges are what decides whether the mesh is closed.
    std::map<std::tuple<float, float, float>, std::uint32_t> seen;
    std::vector<std::uint32_t> remap(points.size());
    std::vector<glm::vec3> unique;
    for (std::size_t i = 0; i < points.size(); ++i) {
        const glm::vec3& q = points[i];
        if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z))
            throw std::invalid_argument(what + ": point " + std::to_string(i) + " is not finite");
        auto [it, added] = seen.try_emplace({q.x, q.y, q.z}, static_cast<std::uint32_t>(unique.size()));
        if (added) unique.push_back(q);
        remap[i] = it->second;
    }
    std::vector<glm::uvec3> tris;
    tris.reserve(triangles.size());
    for (const auto& t : triangles) {
        if (t.x >= points.size() || t.y >= points.size() || t.z >= points.size())
            throw std::invalid_argument(what + ": a triangle names a point out of range");
        const glm::uvec3 u(remap[t.x], remap[t.y], remap[t.z]);
        if (u.x == u.y || u.y == u.z || u.z == u.x) continue;
        if (glm::length(glm::cross(unique[u.y] - unique[u.x], unique[u.z] - unique[u.x])) > 0.f) tris.push_back(u);
    }
    if (tris.size() < 4) throw std::invalid_argument(what + ": fewer than 4 triangles of non-zero area");
    auto f = std::make_shared<Polyhedron>(std::move(unique), std::move(tris), std::move(what), trusted);
    if (closed) *closed = f->closed();
    return f;
}

}  // namespace isoforge::csg
