#include "mesh/parametric.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include <glm/geometric.hpp>
#include <glm/vec4.hpp>

#include "core/error.h"
#include "mesh/text_cursor.h"

namespace isoforge::mesh {

glm::dvec3 bezierPoint(std::span<const glm::dvec3> control, double t) {
    if (control.empty()) return glm::dvec3(0.0);
    std::vector<glm::dvec3> d(control.begin(), control.end());
    for (std::size_t r = 1; r < d.size(); ++r)
        for (std::size_t i = 0; i + r < d.size(); ++i) d[i] = (1.0 - t) * d[i] + t * d[i + 1];
    return d[0];
}

glm::dvec3 BezierPatch::evaluate(double u, double v) const {
    std::vector<glm::dvec3> column(std::size_t(degreeV) + 1);
    for (int j = 0; j <= degreeV; ++j)
        column[std::size_t(j)] = bezierPoint(std::span<const glm::dvec3>(&at(0, j), std::size_t(degreeU) + 1), u);
    return bezierPoint(column, v);
}

// ---------------------------------------------------------------------------------------------
// The .bpt reader

std::vector<BezierPatch> readBezierPatches(const std::filesystem::path& path) {
    const std::string data = detail::readWholeFile(path, "a Bézier patch file (.bpt)");
    detail::TextCursor in(data, path.string());
    auto next = [&](const char* what) {
        in.skipWhitespace();
        while (in.peek() == '#') {  // comments, which some copies carry
            in.nextLine();
            in.skipWhitespace();
        }
        if (in.atEnd()) in.fail(std::string("unexpected end of file: expected ") + what);
    };
    next("the number of patches");
    const long long count = in.number<long long>("the number of patches");
    if (count < 1 || count > 1000000) in.fail("expected a number of patches from 1 to 1,000,000");
    // Every patch needs at least 4 points of 3 numbers: a count the file cannot hold is refused
    // before anything is allocated.
    if (std::size_t(count) * 12 > data.size())
        in.fail("the file says " + std::to_string(count) + " patches but is only " + std::to_string(data.size()) +
                " bytes long");
    std::vector<BezierPatch> patches(static_cast<std::size_t>(count));
    for (std::size_t k = 0; k < patches.size(); ++k) {
        BezierPatch& p = patches[k];
        const std::string patch = "patch " + std::to_string(k + 1) + " of " + std::to_string(count);
        next(("the degrees of " + patch).c_str());
        p.degreeU = in.number<int>([&] { return "the degree in u of " + patch; });
        p.degreeV = in.number<int>([&] { return "the degree in v of " + patch; });
        if (p.degreeU < 1 || p.degreeU > 20 || p.degreeV < 1 || p.degreeV > 20)
            in.fail("degrees of " + patch + " must be from 1 to 20");
        const int n = (p.degreeU + 1) * (p.degreeV + 1);
        p.points.resize(std::size_t(n));
        for (int i = 0; i < n; ++i)
            for (int c = 0; c < 3; ++c) {
                auto what = [&] {
                    return std::string("xyz").substr(std::size_t(c), 1) + " of point " + std::to_string(i + 1) +
                           " of " + std::to_string(n) + " of " + patch;
                };
                in.skipWhitespace();
                if (in.atEnd()) in.fail("unexpected end of file: expected " + what());
                p.points[std::size_t(i)][c] = in.number<double>(what);
            }
    }
    in.skipWhitespace();
    if (!in.atEnd()) in.fail("expected the end of the file after " + std::to_string(count) + " patches");
    return patches;
}

// ---------------------------------------------------------------------------------------------
// B-splines and NURBS

namespace {

void validateKnots(const std::vector<double>& knots, std::size_t count, int degree, const char* which) {
    const std::string w = which;
    if (degree < 1 || degree > 20) throw std::invalid_argument(w + "degree must be from 1 to 20");
    if (count < std::size_t(degree) + 1)
        throw std::invalid_argument(w + "degree " + std::to_string(degree) + " needs at least " +
                                    std::to_string(degree + 1) + " control points, got " + std::to_string(count));
    if (knots.size() != count + std::size_t(degree) + 1)
        throw std::invalid_argument(
            w + "knots: " + std::to_string(count) + " control points of degree " + std::to_string(degree) + " need " +
            std::to_string(count + std::size_t(degree) + 1) + " knots, got " + std::to_string(knots.size()));
    for (std::size_t i = 0; i < knots.size(); ++i) {
        if (!std::isfinite(knots[i])) throw std::invalid_argument(w + "knot " + std::to_string(i) + " is not finite");
        if (i > 0 && knots[i] < knots[i - 1])
            throw std::invalid_argument(w + "knots must not decrease (knot " + std::to_string(i) + ")");
    }
    if (!(knots[std::size_t(degree)] < knots[count]))
        throw std::invalid_argument(w + "knots leave an empty domain [knots[degree], knots[count]]");
    for (std::size_t i = 1; i + 1 < knots.size(); ++i) {
        std::size_t m = 1;
        while (i + m < knots.size() - 1 && knots[i + m] == knots[i]) ++m;
        if (m > std::size_t(degree) + 1)
            throw std::invalid_argument(w + "an interior knot repeats more than degree + 1 times");
    }
}

void validateWeights(const std::vector<double>& weights, std::size_t count) {
    if (weights.empty()) return;
    if (weights.size() != count)
        throw std::invalid_argument("weights: " + std::to_string(count) + " control points need " +
                                    std::to_string(count) + " weights, got " + std::to_string(weights.size()));
    for (double w : weights)
        if (!(w > 0.0) || !std::isfinite(w)) throw std::invalid_argument("weights must be positive and finite");
}

/// The knot span k with knots[k] <= t < knots[k + 1] inside the domain (the last non-empty span at
/// its end).
std::size_t findSpan(const std::vector<double>& knots, std::size_t count, int degree, double t) {
    const auto p = std::size_t(degree);
    if (t >= knots[count]) {
        std::size_t k = count - 1;
        while (k > p && knots[k] == knots[count]) --k;
        return k;
    }
    if (t <= knots[p]) {
        std::size_t k = p;
        while (knots[k + 1] == knots[p]) ++k;
        return k;
    }
    // The last k in [p, count - 1] with knots[k] <= t.
    const auto it = std::upper_bound(knots.begin() + std::ptrdiff_t(p), knots.begin() + std::ptrdiff_t(count), t);
    return std::size_t(it - knots.begin()) - 1;
}

/// de Boor's algorithm on homogeneous points d[0..p] (those of span k), in place; returns the point.
glm::dvec4 deBoor(std::vector<glm::dvec4>& d, const std::vector<double>& knots, std::size_t k, int degree, double t) {
    const auto p = std::size_t(degree);
    for (std::size_t r = 1; r <= p; ++r)
        for (std::size_t j = p; j >= r; --j) {
            const double lo = knots[j + k - p], hi = knots[j + 1 + k - r];
            const double a = (t - lo) / (hi - lo);  // hi > lo for a non-empty span k
            d[j] = (1.0 - a) * d[j - 1] + a * d[j];
        }
    return d[p];
}

glm::dvec4 homogeneous(const glm::dvec3& p, double w) {
    return glm::dvec4(p * w, w);
}

/// Control points must be finite (a NaN from `0 % 0` in a scene would reach the tessellation).
void validatePoints(const std::vector<glm::dvec3>& points) {
    for (std::size_t i = 0; i < points.size(); ++i)
        if (!std::isfinite(points[i].x) || !std::isfinite(points[i].y) || !std::isfinite(points[i].z))
            throw std::invalid_argument("control point " + std::to_string(i + 1) + " of " +
                                        std::to_string(points.size()) + " is not finite");
}

}  // namespace

void NurbsCurve::validate() const {
    validatePoints(points);
    validateKnots(knots, points.size(), degree, "");
    validateWeights(weights, points.size());
}

glm::dvec3 NurbsCurve::evaluate(double t) const {
    t = std::clamp(t, domainBegin(), domainEnd());
    const std::size_t k = findSpan(knots, points.size(), degree, t);
    std::vector<glm::dvec4> d(std::size_t(degree) + 1);
    for (std::size_t j = 0; j < d.size(); ++j) {
        const std::size_t i = j + k - std::size_t(degree);
        d[j] = homogeneous(points[i], weights.empty() ? 1.0 : weights[i]);
    }
    const glm::dvec4 h = deBoor(d, knots, k, degree, t);
    return glm::dvec3(h) / h.w;
}

void NurbsSurface::validate() const {
    if (countU < 1 || countV < 1 || points.size() != std::size_t(countU) * std::size_t(countV))
        throw std::invalid_argument(
            "a NURBS surface needs countU x countV = " + std::to_string(std::max(countU, 0) * std::max(countV, 0)) +
            " control points, got " + std::to_string(points.size()));
    validatePoints(points);
    validateKnots(knotsU, std::size_t(countU), degreeU, "u ");
    validateKnots(knotsV, std::size_t(countV), degreeV, "v ");
    validateWeights(weights, points.size());
}

glm::dvec3 NurbsSurface::evaluate(double u, double v) const {
    const auto nu = std::size_t(countU), nv = std::size_t(countV);
    u = std::clamp(u, knotsU[std::size_t(degreeU)], knotsU[nu]);
    v = std::clamp(v, knotsV[std::size_t(degreeV)], knotsV[nv]);
    const std::size_t ku = findSpan(knotsU, nu, degreeU, u), kv = findSpan(knotsV, nv, degreeV, v);
    std::vector<glm::dvec4> row(std::size_t(degreeU) + 1), column(std::size_t(degreeV) + 1);
    for (std::size_t jj = 0; jj < column.size(); ++jj) {
        const std::size_t j = jj + kv - std::size_t(degreeV);
        for (std::size_t ii = 0; ii < row.size(); ++ii) {
            const std::size_t i = ii + ku - std::size_t(degreeU), idx = j * nu + i;
            row[ii] = homogeneous(points[idx], weights.empty() ? 1.0 : weights[idx]);
        }
        column[jj] = deBoor(row, knotsU, ku, degreeU, u);
    }
    const glm::dvec4 h = deBoor(column, knotsV, kv, degreeV, v);
    return glm::dvec3(h) / h.w;
}

std::vector<double> clampedUniformKnots(int count, int degree) {
    std::vector<double> k;
    const int spans = count - degree;
    for (int i = 0; i < degree; ++i) k.push_back(0.0);
    for (int i = 0; i <= spans; ++i) k.push_back(double(i) / double(std::max(spans, 1)));
    for (int i = 0; i < degree; ++i) k.push_back(1.0);
    return k;
}

std::vector<double> uniformKnots(int count, int degree) {
    std::vector<double> k(std::size_t(count + degree + 1));
    for (std::size_t i = 0; i < k.size(); ++i) k[i] = double(i);
    return k;
}

NurbsCurve nurbsCircle(double r) {
    const double s = std::sqrt(0.5);
    NurbsCurve c;
    c.degree = 2;
    c.knots = {0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1};
    c.points = {{r, 0, 0},   {r, r, 0},  {0, r, 0},  {-r, r, 0}, {-r, 0, 0},
                {-r, -r, 0}, {0, -r, 0}, {r, -r, 0}, {r, 0, 0}};
    c.weights = {1, s, 1, s, 1, s, 1, s, 1};
    return c;
}

NurbsSurface revolve(const NurbsCurve& profile) {
    profile.validate();
    const NurbsCurve circle = nurbsCircle(1.0);
    NurbsSurface s;
    s.degreeU = circle.degree;
    s.degreeV = profile.degree;
    s.countU = int(circle.points.size());
    s.countV = int(profile.points.size());
    s.knotsU = circle.knots;
    s.knotsV = profile.knots;
    for (std::size_t j = 0; j < profile.points.size(); ++j) {
        const glm::dvec3& q = profile.points[j];
        const double wq = profile.weights.empty() ? 1.0 : profile.weights[j];
        for (std::size_t i = 0; i < circle.points.size(); ++i) {
            s.points.emplace_back(q.x * circle.points[i].x, q.x * circle.points[i].y, q.z);
            s.weights.push_back(wq * circle.weights[i]);
        }
    }
    return s;
}

NurbsSurface nurbsSphere(double r) {
    const double s = std::sqrt(0.5);
    NurbsCurve half;  // from the south pole up the +x side to the north pole, in the xz plane
    half.degree = 2;
    half.knots = {0, 0, 0, 0.5, 0.5, 1, 1, 1};
    half.points = {{0, 0, -r}, {r, 0, -r}, {r, 0, 0}, {r, 0, r}, {0, 0, r}};
    half.weights = {1, s, 1, s, 1};
    return revolve(half);
}

NurbsSurface nurbsTorus(double majorRadius, double minorRadius) {
    NurbsCurve c = nurbsCircle(minorRadius);  // counter-clockwise in (x, z) seen from -y: outward after revolving
    for (glm::dvec3& p : c.points) p = glm::dvec3(majorRadius + p.x, 0.0, p.y);
    return revolve(c);
}

// ---------------------------------------------------------------------------------------------
// Tessellation

namespace {

/// Collects grids of evaluated points, welds coincident positions (within a tolerance relative to the
/// size of the whole) and drops triangles that collapse.
class GridMesher {
public:
    void addGrid(int resolution, const std::vector<glm::dvec3>& grid) {
        const auto n = std::size_t(resolution) + 1;
        const auto base = static_cast<std::uint32_t>(points_.size());
        points_.insert(points_.end(), grid.begin(), grid.end());
        for (std::size_t j = 0; j + 1 < n; ++j)
            for (std::size_t i = 0; i + 1 < n; ++i) {
                const auto a = base + std::uint32_t(j * n + i), b = a + 1, c = a + std::uint32_t(n) + 1,
                           d = a + std::uint32_t(n);
                quads_.push_back({a, b, c, d});
            }
    }

    TriMesh finish() const {
        TriMesh m;
        if (points_.empty()) return m;
        for (const glm::dvec3& p : points_)  // finite control points can still overflow
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
                throw std::invalid_argument("the surface has points that are not finite (control points too large?)");
        glm::dvec3 lo = points_[0], hi = points_[0];
        for (const glm::dvec3& p : points_) {
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
        }
        const double extent = glm::length(hi - lo);
        if (!std::isfinite(extent)) throw std::invalid_argument("the surface spans more than the largest double");
        const double eps = std::max(extent, 1e-30) * 1e-9;  // cells below stay within 2e9 of lo
        // Weld: cells of size eps; a point joins an earlier point within eps in its or a neighbouring cell.
        using Cell = std::array<long long, 3>;
        auto cellOf = [&](const glm::dvec3& p) {
            const glm::dvec3 c = glm::floor((p - lo) / eps);
            return Cell{static_cast<long long>(c.x), static_cast<long long>(c.y), static_cast<long long>(c.z)};
        };
        auto key = [](const Cell& c) {
            return std::uint64_t(c[0]) * 0x9E3779B97F4A7C15ull ^ std::uint64_t(c[1]) * 0xC2B2AE3D27D4EB4Full ^
                   std::uint64_t(c[2]) * 0x165667B19E3779F9ull;
        };
        std::unordered_multimap<std::uint64_t, std::uint32_t> cells;
        std::vector<glm::dvec3> kept;  // the welded positions, in double
        std::vector<std::uint32_t> remap(points_.size());
        constexpr std::uint32_t kNone = 0xFFFFFFFFu;
        for (std::size_t i = 0; i < points_.size(); ++i) {
            const Cell c = cellOf(points_[i]);
            std::uint32_t found = kNone;
            for (long long dz = -1; dz <= 1; ++dz)
                for (long long dy = -1; dy <= 1; ++dy)
                    for (long long dx = -1; dx <= 1; ++dx) {
                        auto [b, e] = cells.equal_range(key({c[0] + dx, c[1] + dy, c[2] + dz}));
                        for (auto it = b; it != e; ++it)
                            if (glm::length(kept[it->second] - points_[i]) <= eps && it->second < found)
                                found = it->second;  // the first kept point within eps: deterministic
                    }
            if (found == kNone) {
                found = static_cast<std::uint32_t>(kept.size());
                kept.push_back(points_[i]);
                m.positions.emplace_back(points_[i]);
                cells.emplace(key(c), found);
            }
            remap[i] = found;
        }
        auto add = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
            a = remap[a], b = remap[b], c = remap[c];
            if (a != b && b != c && c != a) m.triangles.emplace_back(a, b, c);
        };
        for (const auto& q : quads_) {
            // Split along the shorter diagonal: better triangles on sheared patches.
            const double ac = glm::length(points_[q[0]] - points_[q[2]]),
                         bd = glm::length(points_[q[1]] - points_[q[3]]);
            if (ac <= bd) {
                add(q[0], q[1], q[2]);
                add(q[0], q[2], q[3]);
            } else {
                add(q[0], q[1], q[3]);
                add(q[1], q[2], q[3]);
            }
        }
        return m;
    }

private:
    std::vector<glm::dvec3> points_;
    std::vector<std::array<std::uint32_t, 4>> quads_;
};

void checkResolution(int resolution, std::size_t patches) {
    if (resolution < 1 || resolution > 4096)
        throw std::invalid_argument("tessellation resolution must be from 1 to 4096, got " +
                                    std::to_string(resolution));
    const double vertices = double(patches) * double(resolution + 1) * double(resolution + 1);
    if (vertices > 2e8)
        throw ResourceError("tessellating " + std::to_string(patches) + " patches at resolution " +
                            std::to_string(resolution) + " would make " + std::to_string(std::llround(vertices)) +
                            " vertices (about " + std::to_string(std::llround(vertices * 80 / (1 << 20))) +
                            " MiB): use a lower resolution");
}

}  // namespace

TriMesh tessellate(std::span<const BezierPatch> patches, int resolution) {
    checkResolution(resolution, patches.size());
    GridMesher mesher;
    const auto n = std::size_t(resolution) + 1;
    std::vector<glm::dvec3> grid(n * n);
    for (const BezierPatch& p : patches) {
        for (std::size_t j = 0; j < n; ++j)
            for (std::size_t i = 0; i < n; ++i)
                grid[j * n + i] = p.evaluate(double(i) / double(resolution), double(j) / double(resolution));
        mesher.addGrid(resolution, grid);
    }
    return mesher.finish();
}

TriMesh tessellate(const NurbsSurface& s, int resolution) {
    s.validate();
    checkResolution(resolution, 1);
    const double u0 = s.knotsU[std::size_t(s.degreeU)], u1 = s.knotsU[std::size_t(s.countU)];
    const double v0 = s.knotsV[std::size_t(s.degreeV)], v1 = s.knotsV[std::size_t(s.countV)];
    const auto n = std::size_t(resolution) + 1;
    std::vector<glm::dvec3> grid(n * n);
    for (std::size_t j = 0; j < n; ++j)
        for (std::size_t i = 0; i < n; ++i)
            grid[j * n + i] = s.evaluate(u0 + (u1 - u0) * double(i) / double(resolution),
                                         v0 + (v1 - v0) * double(j) / double(resolution));
    GridMesher mesher;
    mesher.addGrid(resolution, grid);
    return mesher.finish();
}

}  // namespace isoforge::mesh
