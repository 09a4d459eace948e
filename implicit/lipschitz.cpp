/// @file A bound on a tape's gradient (its Lipschitz constant) from the tape's structure alone, so
/// that a tape that is a distance field in disguise (spheres and slabs as sqrt(dx^2 + dy^2 + dz^2) - r,
/// combined by min and max: most .vm models) can be sphere traced instead of bisected by intervals.
///
/// Each value is tracked as a constant (its value), an affine function of x, y, z (its exact
/// gradient), or a bound L on its gradient's length. The rules:
///   c * a, a / c          scale (an affine value stays affine)
///   a + b, a - b          affine if both are; otherwise L_a + L_b
///   min, max              max(L_a, L_b)        (the gradient is one side's, almost everywhere)
///   neg, abs, sin, cos    L_a                  (|sin'| <= 1)
///   sqrt(sum of squares)  the norm of the stacked gradients: for a vector u of affine values with
///                         Jacobian J, |grad |u|| = |J^T u| / |u| <= ||J||_2 = sqrt(lambda_max(J^T J));
///                         other terms (bounds L_i) add L_i^2 under the root, nonnegative constants
///                         only shrink the gradient. sqrt(dx^2 + dy^2 + dz^2) gives exactly 1.
///   anything else         no bound (infinity): squares, products, exp, log, division by a variable
/// Rounding makes the bound exact only up to float precision, as for every distance field here.

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "implicit/tape.h"

namespace isoforge::implicit {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// What is known about one value.
struct Known {
    enum Kind : std::uint8_t { Constant, Affine, Bounded } kind = Bounded;
    double c = 0;               ///< Constant: the value
    std::array<double, 3> g{};  ///< Affine: the gradient (zero for a constant)
    double L = kInf;            ///< a bound on the gradient's length (every kind)
    /// A sum of squares (and nonnegative constants): sum g g^T over its affine terms and the sum of
    /// L^2 over the others; `squares` false when the value is not one.
    bool squares = false;
    std::array<double, 6> m{};  ///< xx, xy, xz, yy, yz, zz
    double f = 0;
};

double length(const std::array<double, 3>& g) {
    return std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
}

Known constant(double c) {
    Known k;
    k.kind = Known::Constant;
    k.c = c;
    k.L = 0;
    k.squares = c >= 0;
    return k;
}

Known affine(const std::array<double, 3>& g) {
    Known k;
    k.kind = Known::Affine;
    k.g = g;
    k.L = length(g);
    return k;
}

Known bounded(double L) {
    Known k;
    k.L = std::isfinite(L) ? L : kInf;
    return k;
}

Known scaled(const Known& a, double s) {
    if (!std::isfinite(s)) return bounded(kInf);
    if (a.kind == Known::Constant) return constant(a.c * s);
    if (a.kind == Known::Affine) return affine({a.g[0] * s, a.g[1] * s, a.g[2] * s});
    return bounded(a.L * std::abs(s));
}

Known sum(const Known& a, const Known& b, double sign) {
    if (a.kind == Known::Constant && b.kind == Known::Constant) return constant(a.c + sign * b.c);
    Known k;
    if (a.kind != Known::Bounded && b.kind != Known::Bounded)
        k = affine({a.g[0] + sign * b.g[0], a.g[1] + sign * b.g[1], a.g[2] + sign * b.g[2]});
    else
        k = bounded(a.L + b.L);
    if (sign > 0 && a.squares && b.squares) {
        k.squares = true;
        for (int i = 0; i < 6; ++i) k.m[std::size_t(i)] = a.m[std::size_t(i)] + b.m[std::size_t(i)];
        k.f = a.f + b.f;
    }
    return k;
}

Known square(const Known& a) {
    if (a.kind == Known::Constant) return constant(a.c * a.c);
    Known k = bounded(kInf);  // a square alone has no bound; under a sqrt it is a norm's term
    k.squares = std::isfinite(a.L);
    if (a.kind == Known::Affine) {
        const auto& g = a.g;
        k.m = {g[0] * g[0], g[0] * g[1], g[0] * g[2], g[1] * g[1], g[1] * g[2], g[2] * g[2]};
    } else {
        k.f = a.L * a.L;
    }
    return k;
}

/// The largest eigenvalue of a symmetric positive semidefinite 3x3 matrix (xx xy xz yy yz zz), from
/// the roots of its characteristic polynomial in trigonometric form; rounded up a little.
double largestEigenvalue(const std::array<double, 6>& m) {
    const double a = m[0], b = m[3], c = m[5], d = m[1], e = m[4], f = m[2];
    const double off = d * d + e * e + f * f;
    const double q = (a + b + c) / 3;
    if (off <= 1e-30 * (a * a + b * b + c * c)) return std::max({a, b, c}) * (1 + 1e-12);
    const double p2 = (a - q) * (a - q) + (b - q) * (b - q) + (c - q) * (c - q) + 2 * off;
    const double p = std::sqrt(p2 / 6);
    // det((A - qI) / p) / 2
    const double ba = (a - q) / p, bb = (b - q) / p, bc = (c - q) / p, bd = d / p, be = e / p, bf = f / p;
    const double r = (ba * (bb * bc - be * be) - bd * (bd * bc - be * bf) + bf * (bd * be - bb * bf)) / 2;
    const double phi = std::acos(std::clamp(r, -1.0, 1.0)) / 3;
    return (q + 2 * p * std::cos(phi)) * (1 + 1e-9) + 1e-12 * (a + b + c);
}

Known root(const Known& a) {
    if (a.kind == Known::Constant) return constant(std::sqrt(a.c));
    if (!a.squares) return bounded(kInf);
    return bounded(std::sqrt(largestEigenvalue(a.m) + a.f));
}

}  // namespace

float lipschitzBound(const std::vector<Instruction>& code) {
    thread_local std::vector<Known> known;
    known.resize(code.size());
    for (std::size_t i = 0; i < code.size(); ++i) {
        const Instruction& in = code[i];
        const Known& a = known[in.a];
        const Known& b = known[in.b];
        Known k;
        switch (in.op) {
            case Op::Const:
                k = constant(in.imm);
                break;
            case Op::VarX:
                k = affine({1, 0, 0});
                break;
            case Op::VarY:
                k = affine({0, 1, 0});
                break;
            case Op::VarZ:
                k = affine({0, 0, 1});
                break;
            case Op::Add:
                k = sum(a, b, 1);
                break;
            case Op::Sub:
                k = sum(a, b, -1);
                break;
            case Op::Mul:
                k = a.kind == Known::Constant   ? scaled(b, a.c)
                    : b.kind == Known::Constant ? scaled(a, b.c)
                                                : bounded(kInf);
                break;
            case Op::Div:
                k = b.kind == Known::Constant ? scaled(a, 1 / b.c) : bounded(kInf);
                break;
            case Op::Min:
            case Op::Max:
                if (a.kind == Known::Constant && b.kind == Known::Constant)
                    k = constant(in.op == Op::Min ? std::min(a.c, b.c) : std::max(a.c, b.c));
                else
                    k = bounded(std::max(a.L, b.L));
                break;
            case Op::Neg:
                k = scaled(a, -1);
                break;
            case Op::Abs:
                k = a.kind == Known::Constant ? constant(std::abs(a.c)) : bounded(a.L);
                break;
            case Op::Square:
                k = square(a);
                break;
            case Op::Sqrt:
                k = root(a);
                break;
            case Op::Sin:
            case Op::Cos:
                k = a.kind == Known::Constant ? constant(in.op == Op::Sin ? std::sin(a.c) : std::cos(a.c))
                                              : bounded(a.L);
                break;
            case Op::Exp:
            case Op::Log:
                k = a.kind == Known::Constant ? constant(in.op == Op::Exp ? std::exp(a.c) : std::log(a.c))
                                              : bounded(kInf);
                break;
        }
        known[i] = k;
    }
    const double L = known.back().L;
    return L < double(std::numeric_limits<float>::max()) ? static_cast<float>(L * (1 + 1e-6))
                                                         : std::numeric_limits<float>::infinity();
}

}  // namespace isoforge::implicit
