#pragma once
/// @file Interval arithmetic: conservative bounds of functions over boxes. Every operation returns
/// an interval containing all results for arguments in the operand intervals.

#include <algorithm>
#include <cmath>
#include <limits>

namespace isoforge::implicit {

struct Interval {
    float lo = 0.f, hi = 0.f;
    Interval() = default;
    constexpr Interval(float v) : lo(v), hi(v) {}  // NOLINT: a point is an interval
    constexpr Interval(float l, float h) : lo(l), hi(h) {}
    static Interval everything() {
        return {-std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity()};
    }
    bool contains(float v) const { return lo <= v && v <= hi; }
    float width() const { return hi - lo; }
};

inline Interval operator+(Interval a, Interval b) {
    return {a.lo + b.lo, a.hi + b.hi};
}
inline Interval operator-(Interval a, Interval b) {
    return {a.lo - b.hi, a.hi - b.lo};
}
inline Interval operator-(Interval a) {
    return {-a.hi, -a.lo};
}
inline Interval operator*(Interval a, Interval b) {
    const float p[4] = {a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi};
    float lo = p[0], hi = p[0];
    for (float v : p) {
        if (std::isnan(v)) return Interval::everything();  // 0 * inf
        lo = std::min(lo, v);
        hi = std::max(hi, v);
    }
    return {lo, hi};
}
inline Interval operator/(Interval a, Interval b) {
    if (b.lo <= 0.f && b.hi >= 0.f) return Interval::everything();
    return a * Interval(1.f / b.hi, 1.f / b.lo);
}
inline Interval square(Interval a) {
    if (a.lo >= 0.f) return {a.lo * a.lo, a.hi * a.hi};
    if (a.hi <= 0.f) return {a.hi * a.hi, a.lo * a.lo};
    return {0.f, std::max(a.lo * a.lo, a.hi * a.hi)};
}
inline Interval abs(Interval a) {
    if (a.lo >= 0.f) return a;
    if (a.hi <= 0.f) return -a;
    return {0.f, std::max(-a.lo, a.hi)};
}
/// sqrt of the non-negative part (negative arguments give NaN pointwise; the bound ignores them).
inline Interval sqrt(Interval a) {
    return {std::sqrt(std::max(a.lo, 0.f)), std::sqrt(std::max(a.hi, 0.f))};
}
inline Interval exp(Interval a) {
    return {std::exp(a.lo), std::exp(a.hi)};
}
inline Interval log(Interval a) {
    return {a.lo <= 0.f ? -std::numeric_limits<float>::infinity() : std::log(a.lo),
            a.hi <= 0.f ? -std::numeric_limits<float>::infinity() : std::log(a.hi)};
}
inline Interval min(Interval a, Interval b) {
    return {std::min(a.lo, b.lo), std::min(a.hi, b.hi)};
}
inline Interval max(Interval a, Interval b) {
    return {std::max(a.lo, b.lo), std::max(a.hi, b.hi)};
}
inline Interval sin(Interval a) {
    constexpr float kTwoPi = 6.28318530718f, kHalfPi = 1.57079632679f;
    if (!(a.width() < kTwoPi)) return {-1.f, 1.f};
    float lo = std::min(std::sin(a.lo), std::sin(a.hi)), hi = std::max(std::sin(a.lo), std::sin(a.hi));
    // Maxima at pi/2 + 2k pi, minima at -pi/2 + 2k pi inside [lo, hi].
    const float kMax = std::ceil((a.lo - kHalfPi) / kTwoPi), kMin = std::ceil((a.lo + kHalfPi) / kTwoPi);
    if (kHalfPi + kMax * kTwoPi <= a.hi) hi = 1.f;
    if (-kHalfPi + kMin * kTwoPi <= a.hi) lo = -1.f;
    return {lo, hi};
}
inline Interval cos(Interval a) {
    return sin(a + Interval(1.57079632679f));
}
/// A point value widened to a whole interval by a Lipschitz constant and a radius.
inline Interval lipschitz(float centre, float constant, float radius) {
    const float r = constant * radius;
    return {centre - r, centre + r};
}

}  // namespace isoforge::implicit
