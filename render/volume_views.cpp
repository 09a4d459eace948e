#include "render/volume_views.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "render/shading.h"

namespace isoforge::render {

using volume::DenseVolume;

Anatomical parseAnatomical(const std::string& name) {
    if (name == "axial") return Anatomical::Axial;
    if (name == "coronal") return Anatomical::Coronal;
    if (name == "sagittal") return Anatomical::Sagittal;
    throw std::invalid_argument("unknown view '" + name + "' (axial, coronal or sagittal)");
}

ViewAxes viewAxes(const DenseVolume& v, Anatomical view) {
    // World (LPS) directions: across the view, towards the image's right, towards its bottom.
    glm::dvec3 across(0, 0, 1), right(1, 0, 0), down(0, 1, 0);  // axial
    if (view == Anatomical::Coronal) across = {0, 1, 0}, right = {1, 0, 0}, down = {0, 0, -1};
    if (view == Anatomical::Sagittal) across = {1, 0, 0}, right = {0, 1, 0}, down = {0, 0, -1};
    const glm::dmat3 d = v.directions();
    auto best = [&](const glm::dvec3& w, int exclude1, int exclude2) {
        int axis = -1;
        for (int a = 0; a < 3; ++a)
            if (a != exclude1 && a != exclude2 &&
                (axis < 0 || std::abs(glm::dot(d[a], w)) > std::abs(glm::dot(d[axis], w))))
                axis = a;
        return axis;
    };
    ViewAxes va;
    va.slice = best(across, -1, -1);
    va.right = best(right, va.slice, -1);
    va.down = 3 - va.slice - va.right;
    va.flipRight = glm::dot(d[va.right], right) < 0;
    va.flipDown = glm::dot(d[va.down], down) < 0;
    return va;
}

namespace {

float srgbToLinear(float c) {
    return detail::srgbToLinear1(std::clamp(c, 0.f, 1.f));
}

glm::vec3 colormap(const std::string& name, float t) {
    t = std::clamp(t, 0.f, 1.f);
    if (name == "hot") return {std::min(1.f, 3 * t), std::clamp(3 * t - 1, 0.f, 1.f), std::clamp(3 * t - 2, 0.f, 1.f)};
    if (name == "bone") {
        const glm::vec3 a = glm::vec3(t * 7.f / 8.f) + glm::vec3(0, 0, std::min(t, 0.375f) / 3.f) +
                            glm::vec3(0, std::clamp(t - 0.375f, 0.f, 0.375f) / 3.f, 0) +
                            glm::vec3(std::max(t - 0.75f, 0.f) / 2.f, 0, 0);
        return glm::clamp(a, 0.f, 1.f);
    }
    if (name == "viridis") {
        static const glm::vec3 stops[] = {{0.267f, 0.005f, 0.329f}, {0.283f, 0.141f, 0.458f}, {0.254f, 0.265f, 0.530f},
                                          {0.207f, 0.372f, 0.553f}, {0.164f, 0.471f, 0.558f}, {0.128f, 0.567f, 0.551f},
                                          {0.135f, 0.659f, 0.518f}, {0.267f, 0.749f, 0.441f}, {0.478f, 0.821f, 0.318f},
                                          {0.741f, 0.873f, 0.150f}, {0.993f, 0.906f, 0.144f}};
        const float x = t * 10.f;
        const int i = std::min(int(x), 9);
        return glm::mix(stops[i], stops[i + 1], x - float(i));
    }
    return glm::vec3(t);  // grey
}

/// Bilinear sample in the plane of a slice (index coordinates u along `ax`, w along `ay`; the slice
/// coordinate fixed), clamped to the volume.
struct Sampler {
    const DenseVolume& v;
    float at(std::array<std::int64_t, 3> c) const {
        for (int a = 0; a < 3; ++a)
            c[std::size_t(a)] = std::clamp<std::int64_t>(c[std::size_t(a)], 0, v.dims[std::size_t(a)] - 1);
        return v.at(c[0], c[1], c[2]);
    }
    /// Trilinear at index position p (voxel centres at integers).
    float trilinear(const glm::dvec3& p) const {
        const glm::dvec3 f = glm::floor(p);
        const glm::dvec3 t = p - f;
        const auto x = std::int64_t(f.x), y = std::int64_t(f.y), z = std::int64_t(f.z);
        float c[2][2][2];
        for (int dz = 0; dz < 2; ++dz)
            for (int dy = 0; dy < 2; ++dy)
                for (int dx = 0; dx < 2; ++dx) c[dz][dy][dx] = at({x + dx, y + dy, z + dz});
        auto lerp = [](float a, float b, double w) { return float(a + (b - a) * w); };
        const float c00 = lerp(c[0][0][0], c[0][0][1], t.x), c01 = lerp(c[0][1][0], c[0][1][1], t.x),
                    c10 = lerp(c[1][0][0], c[1][0][1], t.x), c11 = lerp(c[1][1][0], c[1][1][1], t.x);
        return lerp(lerp(c00, c01, t.y), lerp(c10, c11, t.y), t.z);
    }
};

/// Size of the square-pixel image of a view, and the index coordinate of each pixel centre.
struct PlaneMap {
    ViewAxes axes;
    int width = 0, height = 0;
    double pixel = 1;  ///< mm
    PlaneMap(const DenseVolume& v, Anatomical view) : axes(viewAxes(v, view)) {
        const glm::dvec3 sp = v.spacing();
        pixel = std::min(sp[axes.right], sp[axes.down]);
        width = std::max(1, int(std::lround(double(v.dims[std::size_t(axes.right)]) * sp[axes.right] / pixel)));
        height = std::max(1, int(std::lround(double(v.dims[std::size_t(axes.down)]) * sp[axes.down] / pixel)));
        nr_ = double(v.dims[std::size_t(axes.right)]);
        nd_ = double(v.dims[std::size_t(axes.down)]);
    }
    /// Index coordinates (continuous, voxel centres at integers) along the right and down axes.
    std::pair<double, double> index(int px, int py) const {
        double r = (double(px) + 0.5) / double(width) * nr_ - 0.5, d = (double(py) + 0.5) / double(height) * nd_ - 0.5;
        if (axes.flipRight) r = nr_ - 1 - r;
        if (axes.flipDown) d = nd_ - 1 - d;
        return {r, d};
    }

private:
    double nr_ = 1, nd_ = 1;
};

Image toDisplay(const std::vector<float>& values, int w, int h, const DenseVolume& v, const SliceLook& look) {
    Image img(w, h, 3);
    auto [lo, hi] = v.range();
    float window = look.wl.window, level = look.wl.level;
    if (!(window > 0)) {
        window = std::max(hi - lo, 1e-6f);
        level = 0.5f * (lo + hi);
    }
    for (std::size_t i = 0; i < values.size(); ++i) {
        glm::vec3 c;
        if (look.colormap == "labels") {
            const long label = std::lround(values[i]);
            if (label == 0) {
                c = glm::vec3(0.f);
            } else {
                std::array<float, 3> col = volume::defaultLabelColor(int(label));
                if (look.labels)
                    if (auto it = look.labels->find(int(label)); it != look.labels->end() && it->second.hasColor)
                        col = it->second.color;
                c = {col[0], col[1], col[2]};
            }
        } else {
            c = colormap(look.colormap, (values[i] - (level - 0.5f * window)) / window);
        }
        float* p = img.pixels.data() + 3 * i;
        for (int k = 0; k < 3; ++k) p[k] = srgbToLinear(c[k]);  // display values, so the file holds them as given
    }
    return img;
}

}  // namespace

Image sliceVolume(const DenseVolume& v, Anatomical view, std::int64_t index, const SliceLook& look) {
    const PlaneMap map(v, view);
    const std::int64_t n = v.dims[std::size_t(map.axes.slice)];
    if (index < 0 || index >= n)
        throw std::out_of_range("slice index " + std::to_string(index) + " is outside 0.." + std::to_string(n - 1));
    const Sampler s{v};
    std::vector<float> values(std::size_t(map.width) * std::size_t(map.height));
    const bool nearest = look.colormap == "labels";
    for (int y = 0; y < map.height; ++y)
        for (int x = 0; x < map.width; ++x) {
            const auto [r, d] = map.index(x, y);
            glm::dvec3 p;
            p[map.axes.slice] = double(index);
            p[map.axes.right] = nearest ? std::round(r) : r;
            p[map.axes.down] = nearest ? std::round(d) : d;
            values[std::size_t(y) * std::size_t(map.width) + std::size_t(x)] = s.trilinear(p);
        }
    return toDisplay(values, map.width, map.height, v, look);
}

Image maximumIntensityProjection(const DenseVolume& v, Anatomical view, const SliceLook& look) {
    const PlaneMap map(v, view);
    const ViewAxes& a = map.axes;
    // The projection at native resolution first (max along the slice axis), then resampled.
    const auto nr = v.dims[std::size_t(a.right)], nd = v.dims[std::size_t(a.down)], ns = v.dims[std::size_t(a.slice)];
    std::vector<float> mip(std::size_t(nr * nd), -std::numeric_limits<float>::infinity());
    for (std::int64_t k = 0; k < ns; ++k)
        for (std::int64_t j = 0; j < nd; ++j)
            for (std::int64_t i = 0; i < nr; ++i) {
                std::array<std::int64_t, 3> c{};
                c[std::size_t(a.slice)] = k;
                c[std::size_t(a.right)] = i;
                c[std::size_t(a.down)] = j;
                float& m = mip[std::size_t(j * nr + i)];
                m = std::max(m, v.at(c[0], c[1], c[2]));
            }
    std::vector<float> values(std::size_t(map.width) * std::size_t(map.height));
    for (int y = 0; y < map.height; ++y)
        for (int x = 0; x < map.width; ++x) {
            const auto [r, d] = map.index(x, y);
            const double rc = std::clamp(r, 0.0, double(nr - 1)), dc = std::clamp(d, 0.0, double(nd - 1));
            const auto r0 = std::int64_t(rc), d0 = std::int64_t(dc);
            const auto r1 = std::min(r0 + 1, nr - 1), d1 = std::min(d0 + 1, nd - 1);
            const double tr = rc - double(r0), td = dc - double(d0);
            auto at = [&](std::int64_t i, std::int64_t j) { return double(mip[std::size_t(j * nr + i)]); };
            values[std::size_t(y) * std::size_t(map.width) + std::size_t(x)] = float(
                (at(r0, d0) * (1 - tr) + at(r1, d0) * tr) * (1 - td) + (at(r0, d1) * (1 - tr) + at(r1, d1) * tr) * td);
        }
    return toDisplay(values, map.width, map.height, v, look);
}

// ---------------------------------------------------------------------------------------------
// Transfer functions

void TransferFunction::sample(float value, std::array<float, 3>& color, float& opacity) const {
    if (points.empty()) {
        color = {0, 0, 0};
        opacity = 0;
        return;
    }
    if (value <= points.front().value) {
        color = points.front().color;
        opacity = points.front().opacity;
        return;
    }
    for (std::size_t i = 1; i < points.size(); ++i)
        if (value <= points[i].value) {
            const Point &a = points[i - 1], &b = points[i];
            const float t = b.value > a.value ? (value - a.value) / (b.value - a.value) : 1.f;
            for (int c = 0; c < 3; ++c)
                color[std::size_t(c)] =
                    a.color[std::size_t(c)] + t * (b.color[std::size_t(c)] - a.color[std::size_t(c)]);
            opacity = a.opacity + t * (b.opacity - a.opacity);
            return;
        }
    color = points.back().color;
    opacity = points.back().opacity;
}

TransferFunction transferPreset(const std::string& name, float lo, float hi) {
    TransferFunction tf;
    if (name == "ct-bone") {  // Hounsfield units: soft tissue clear, bone from 150 HU up
        tf.points = {{-1000, {0, 0, 0}, 0},
                     {150, {0.75f, 0.35f, 0.2f}, 0},
                     {300, {0.95f, 0.8f, 0.6f}, 0.3f},
                     {700, {1, 0.95f, 0.85f}, 1.2f},
                     {1500, {1, 1, 0.97f}, 2.f}};
    } else if (name == "ct-soft") {  // skin and fat faint, muscle and organs red, bone white
        tf.points = {{-1000, {0, 0, 0}, 0},
                     {-600, {0.6f, 0.4f, 0.3f}, 0},
                     {-100, {0.9f, 0.7f, 0.55f}, 0.004f},
                     {20, {0.8f, 0.3f, 0.25f}, 0.01f},
                     {80, {0.85f, 0.35f, 0.3f}, 0.06f},
                     {250, {1, 0.95f, 0.9f}, 0.5f},
                     {1000, {1, 1, 1}, 1.5f}};
    } else if (name == "mr") {  // MR has no absolute scale: fractions of the range
        const float r = std::max(hi - lo, 1e-6f);
        tf.points = {{lo + 0.1f * r, {0, 0, 0}, 0},
                     {lo + 0.3f * r, {0.6f, 0.55f, 0.5f}, 0.02f},
                     {lo + 0.6f * r, {0.9f, 0.85f, 0.8f}, 0.15f},
                     {hi, {1, 1, 1}, 0.6f}};
    } else {
        throw std::invalid_argument("unknown transfer-function preset '" + name + "' (ct-bone, ct-soft, mr)");
    }
    return tf;
}

TransferFunction parseTransferFunction(const std::string& text) {
    TransferFunction tf;
    std::istringstream in(text);
    std::string point;
    int n = 0;
    while (in >> point) {
        ++n;
        const auto colon = point.find(':');
        float v = 0, r = 0, g = 0, b = 0, a = 0;
        char extra = 0;
        if (colon == std::string::npos ||
            std::sscanf(point.c_str(), "%f:%f,%f,%f,%f%c", &v, &r, &g, &b, &a, &extra) != 5)
            throw std::invalid_argument("transfer-function point " + std::to_string(n) + " '" + point +
                                        "': expected VALUE:R,G,B,A");
        if (!tf.points.empty() && v < tf.points.back().value)
            throw std::invalid_argument("transfer-function point " + std::to_string(n) + ": values must not decrease");
        tf.points.push_back({v, {r, g, b}, std::max(a, 0.f)});
    }
    if (tf.points.empty()) throw std::invalid_argument("empty transfer function");
    return tf;
}

implicit::Box3 volumeBounds(const DenseVolume& v) {
    implicit::Box3 b;
    for (int c = 0; c < 8; ++c) {
        const glm::dvec4 p =
            v.indexToWorld * glm::dvec4(c & 1 ? double(v.dims[0]) - 0.5 : -0.5, c & 2 ? double(v.dims[1]) - 0.5 : -0.5,
                                        c & 4 ? double(v.dims[2]) - 0.5 : -0.5, 1.0);
        const glm::vec3 q(p);
        b = b.unite(implicit::Box3{q, q});
    }
    return b;
}

namespace {

/// A ray in the volume's index space: origin and direction (not unit: t stays the world distance).
struct IndexRay {
    glm::dvec3 o, d;
    double t0 = 0, t1 = -1;  ///< inside the voxel box [-0.5, n - 0.5]
};

void fillStats(RenderStats* stats, std::chrono::steady_clock::time_point start, const RenderOptions& o,
               std::uint64_t hits) {
    if (!stats) return;
    stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    stats->primaryRays = std::uint64_t(o.width) * std::uint64_t(o.height) * std::uint64_t(o.spp);
    stats->hitPixels = hits;
}

IndexRay toIndex(const glm::dmat4& worldToIndex, const DenseVolume& v, const detail::Ray& r) {
    IndexRay ir;
    ir.o = glm::dvec3(worldToIndex * glm::dvec4(glm::dvec3(r.origin), 1.0));
    ir.d = glm::dvec3(worldToIndex * glm::dvec4(glm::dvec3(r.dir), 0.0));
    double t0 = 0, t1 = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
        const double lo = -0.5, hi = double(v.dims[std::size_t(a)]) - 0.5;
        if (std::abs(ir.d[a]) < 1e-300) {
            if (ir.o[a] < lo || ir.o[a] > hi) return ir;
            continue;
        }
        double ta = (lo - ir.o[a]) / ir.d[a], tb = (hi - ir.o[a]) / ir.d[a];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
    }
    ir.t0 = t0;
    ir.t1 = t1;
    return ir;
}

}  // namespace

Frame renderVolume(const DenseVolume& v, const TransferFunction& tf, const Look& look, const RenderOptions& o,
                   RenderStats* stats) {
    const auto start = std::chrono::steady_clock::now();
    const glm::dmat4 w2i = glm::inverse(v.indexToWorld);
    const glm::dmat3 gradToWorld = glm::transpose(glm::dmat3(w2i));
    const glm::dvec3 sp = v.spacing();
    const double step = 0.5 * std::min({sp.x, sp.y, sp.z});
    const Sampler s{v};
    const detail::Background bg(look);
    std::uint64_t hits = 0;
    Frame f = detail::renderTiles(
        look, o,
        [&](const detail::Ray& ray, std::size_t pix, std::size_t, float py) {
            detail::SampleResult res;
            const IndexRay ir = toIndex(w2i, v, ray);
            glm::dvec3 acc(0.0);
            double transmittance = 1.0;
            if (ir.t1 > ir.t0) {
                // A per-pixel offset of the first sample (deterministic) breaks up wood-grain banding.
                const double jitter = detail::hashToUnit(std::uint32_t(pix) * 2654435761u);
                for (double t = ir.t0 + jitter * step; t < ir.t1 && transmittance > 0.01; t += step) {
                    const glm::dvec3 p = ir.o + t * ir.d;
                    const float value = s.trilinear(p);
                    std::array<float, 3> c;
                    float sigma;
                    tf.sample(value, c, sigma);
                    if (sigma <= 0) continue;
                    const double alpha = 1.0 - std::exp(-double(sigma) * step);
                    // Headlight shading from the gradient (index-space central differences to world).
                    const glm::dvec3 g(s.trilinear(p + glm::dvec3(1, 0, 0)) - s.trilinear(p - glm::dvec3(1, 0, 0)),
                                       s.trilinear(p + glm::dvec3(0, 1, 0)) - s.trilinear(p - glm::dvec3(0, 1, 0)),
                                       s.trilinear(p + glm::dvec3(0, 0, 1)) - s.trilinear(p - glm::dvec3(0, 0, 1)));
                    const glm::dvec3 gw = gradToWorld * g;
                    const double len = glm::length(gw);
                    const double light =
                        len > 1e-12 ? 0.35 + 0.65 * std::abs(glm::dot(gw / len, glm::dvec3(ray.dir))) : 1.0;
                    const glm::dvec3 col(srgbToLinear(c[0]), srgbToLinear(c[1]), srgbToLinear(c[2]));
                    acc += transmittance * alpha * light * col;
                    transmittance *= 1.0 - alpha;
                    if (!res.hit) {
                        res.hit = true;
                        res.depth = float(t);
                    }
                }
            }
            res.color = glm::vec3(acc) + float(transmittance) * bg.at(py, o.height);
            return res;
        },
        hits);
    fillStats(stats, start, o, hits);
    return f;
}

Frame renderVoxels(const DenseVolume& v, const volume::LabelTable& labels, const Look& look, const RenderOptions& o,
                   RenderStats* stats) {
    const auto start = std::chrono::steady_clock::now();
    const glm::dmat4 w2i = glm::inverse(v.indexToWorld);
    const glm::dmat3 normalToWorld = glm::transpose(glm::dmat3(w2i));
    const detail::LightSet lights(look);
    const detail::Background bg(look);
    // Linear colour per label value (looked up once).
    std::map<long, glm::vec3> colours;
    auto colourOf = [&](long label) {
        std::array<float, 3> c = volume::defaultLabelColor(int(label));
        if (auto it = labels.find(int(label)); it != labels.end() && it->second.hasColor) c = it->second.color;
        return glm::vec3(srgbToLinear(c[0]), srgbToLinear(c[1]), srgbToLinear(c[2]));
    };
    {
        const auto [lo, hi] = v.range();
        for (long l = std::lround(lo); l <= std::lround(hi) && l - std::lround(lo) < 70000; ++l)
            colours[l] = colourOf(l);
    }
    std::uint64_t hits = 0;
    Frame f = detail::renderTiles(
        look, o,
        [&](const detail::Ray& ray, std::size_t, std::size_t, float py) {
            detail::SampleResult res;
            res.color = bg.at(py, o.height);
            const IndexRay ir = toIndex(w2i, v, ray);
            if (!(ir.t1 > ir.t0)) return res;
            // Amanatides and Woo: voxel (i, j, k) spans [i - 0.5, i + 0.5] in index space.
            const double tIn = ir.t0 + 1e-9;
            glm::dvec3 p = ir.o + tIn * ir.d;
            std::array<std::int64_t, 3> cell, stepDir;
            glm::dvec3 tMax, tDelta;
            int enteredAxis = 0;
            {  // the face the ray entered the box through, for a hit in the first voxel
                double best = -1;
                for (int a = 0; a < 3; ++a) {
                    if (std::abs(ir.d[a]) < 1e-300) continue;
                    const double lo = -0.5, hi = double(v.dims[std::size_t(a)]) - 0.5;
                    const double ta = std::min((lo - ir.o[a]) / ir.d[a], (hi - ir.o[a]) / ir.d[a]);
                    if (ta > best) best = ta, enteredAxis = a;
                }
            }
            for (int a = 0; a < 3; ++a) {
                cell[std::size_t(a)] =
                    std::clamp<std::int64_t>(std::int64_t(std::floor(p[a] + 0.5)), 0, v.dims[std::size_t(a)] - 1);
                stepDir[std::size_t(a)] = ir.d[a] > 0 ? 1 : (ir.d[a] < 0 ? -1 : 0);
                if (stepDir[std::size_t(a)] == 0) {
                    tMax[a] = tDelta[a] = std::numeric_limits<double>::infinity();
                } else {
                    const double boundary = double(cell[std::size_t(a)]) + 0.5 * double(stepDir[std::size_t(a)]);
                    tMax[a] = (boundary - ir.o[a]) / ir.d[a];
                    tDelta[a] = 1.0 / std::abs(ir.d[a]);
                }
            }
            double t = tIn;
            int axis = enteredAxis;
            for (;;) {
                const float value = v.at(cell[0], cell[1], cell[2]);
                const long label = std::lround(value);
                if (label != 0) {
                    glm::dvec3 nIndex(0.0);
                    nIndex[axis] = -double(stepDir[std::size_t(axis)]);
                    glm::dvec3 n = glm::normalize(normalToWorld * nIndex);
                    const glm::dvec3 hitIndex = ir.o + t * ir.d;
                    // Darken near the cube's edges: the distance to the face's border in both in-face axes.
                    double edge = 1.0;
                    for (int a = 0; a < 3; ++a) {
                        if (a == axis) continue;
                        const double fr = hitIndex[a] - double(cell[std::size_t(a)]);
                        edge = std::min(edge, 0.5 - std::abs(fr));
                    }
                    detail::Surface surf;
                    surf.position = glm::vec3(v.indexToWorld * glm::dvec4(hitIndex, 1.0));
                    surf.normal = glm::vec3(n);
                    if (glm::dot(surf.normal, ray.dir) > 0) surf.normal = -surf.normal;
                    auto it = colours.find(label);
                    surf.albedo = it != colours.end() ? it->second : colourOf(label);
                    if (edge < 0.06) surf.albedo *= 0.45f;
                    surf.specular = 0.1f;
                    res.color = detail::shade(surf, ray.dir, lights, look.ambient * 2.f, 1.f,
                                              [](std::size_t, const glm::vec3&) { return true; });
                    res.hit = true;
                    res.depth = float(t);
                    res.normal = surf.normal;
                    res.id = float(label);
                    return res;
                }
                // Step to the next voxel along the axis whose boundary comes first.
                axis = tMax.x < tMax.y ? (tMax.x < tMax.z ? 0 : 2) : (tMax.y < tMax.z ? 1 : 2);
                t = tMax[axis];
                if (t > ir.t1) break;
                cell[std::size_t(axis)] += stepDir[std::size_t(axis)];
                if (cell[std::size_t(axis)] < 0 || cell[std::size_t(axis)] >= v.dims[std::size_t(axis)]) break;
                tMax[axis] += tDelta[axis];
            }
            return res;
        },
        hits);
    fillStats(stats, start, o, hits);
    return f;
}

}  // namespace isoforge::render
