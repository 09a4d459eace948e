#include "implicit/quadric.h"

#include <sstream>
#include <stdexcept>

#include "implicit/tape.h"

namespace isoforge::implicit {

FieldPtr makeQuadric(const std::array<float, 10>& c) {
    // Horner-free direct form: every term is one tape instruction chain.
    std::vector<Instruction> code;
    auto push = [&](Instruction in) {
        code.push_back(in);
        return static_cast<std::uint32_t>(code.size() - 1);
    };
    const std::uint32_t x = push({Op::VarX}), y = push({Op::VarY}), z = push({Op::VarZ});
    std::uint32_t sum = push({Op::Const, 0, 0, c[9]});
    // Terms with a zero coefficient emit nothing: the sum must stay the tape's last instruction.
    auto term = [&](float k, auto make) {
        if (k == 0.f) return;
        const std::uint32_t v = make();
        const std::uint32_t t = push({Op::Mul, push({Op::Const, 0, 0, k}), v});
        sum = push({Op::Add, sum, t});
    };
    term(c[0], [&] { return push({Op::Square, x}); });
    term(c[1], [&] { return push({Op::Square, y}); });
    term(c[2], [&] { return push({Op::Square, z}); });
    term(c[3], [&] { return push({Op::Mul, x, y}); });
    term(c[4], [&] { return push({Op::Mul, y, z}); });
    term(c[5], [&] { return push({Op::Mul, z, x}); });
    term(c[6], [&] { return x; });
    term(c[7], [&] { return y; });
    term(c[8], [&] { return z; });
    std::ostringstream d;
    d << "quadric(";
    for (int i = 0; i < 10; ++i) d << (i ? ", " : "") << c[static_cast<std::size_t>(i)];
    d << ")";
    return makeTapeField(std::make_shared<const Tape>(std::move(code)), Box3::everything(), d.str());
}

const std::vector<std::string>& quadricTypes() {
    static const std::vector<std::string> t = {"ellipsoid",           "sphere",
                                               "elliptic_cylinder",   "elliptic_cone",
                                               "hyperboloid1",        "hyperboloid2",
                                               "elliptic_paraboloid", "hyperbolic_paraboloid",
                                               "parabolic_cylinder",  "hyperbolic_cylinder",
                                               "parallel_planes",     "intersecting_planes"};
    return t;
}

FieldPtr makeNamedQuadric(const std::string& type, float a, float b, float c) {
    if (!(a > 0 && b > 0 && c > 0)) throw std::invalid_argument("quadric: a, b and c must be positive");
    const float A = 1 / (a * a), B = 1 / (b * b), C = 1 / (c * c);
    std::array<float, 10> k{};
    if (type == "ellipsoid")
        k = {A, B, C, 0, 0, 0, 0, 0, 0, -1};
    else if (type == "sphere")
        k = {A, A, A, 0, 0, 0, 0, 0, 0, -1};
    else if (type == "elliptic_cylinder")
        k = {A, B, 0, 0, 0, 0, 0, 0, 0, -1};
    else if (type == "elliptic_cone")
        k = {A, B, -C, 0, 0, 0, 0, 0, 0, 0};
    else if (type == "hyperboloid1")
        k = {A, B, -C, 0, 0, 0, 0, 0, 0, -1};
    else if (type == "hyperboloid2")
        k = {-A, -B, C, 0, 0, 0, 0, 0, 0, -1};
    else if (type == "elliptic_paraboloid")
        k = {A, B, 0, 0, 0, 0, 0, 0, -1, 0};
    else if (type == "hyperbolic_paraboloid")
        k = {A, -B, 0, 0, 0, 0, 0, 0, -1, 0};
    else if (type == "parabolic_cylinder")
        k = {A, 0, 0, 0, 0, 0, 0, -1, 0, 0};
    else if (type == "hyperbolic_cylinder")
        k = {A, -B, 0, 0, 0, 0, 0, 0, 0, -1};
    else if (type == "parallel_planes")
        k = {A, 0, 0, 0, 0, 0, 0, 0, 0, -1};
    else if (type == "intersecting_planes")
        k = {A, -B, 0, 0, 0, 0, 0, 0, 0, 0};
    else {
        std::string known;
        for (const auto& t : quadricTypes()) known += (known.empty() ? "" : ", ") + t;
        throw std::invalid_argument("unknown quadric type '" + type + "' (known: " + known + ")");
    }
    FieldPtr f = makeQuadric(k);
    if (type == "ellipsoid" || type == "sphere") {
        // Bounded: report its box so it needs no clipping.
        struct Bounded final : Field {
            FieldPtr f;
            Box3 box;
            float value(const glm::vec3& p) const override { return f->value(p); }
            void values(std::span<const glm::vec3> p, std::span<float> o) const override { f->values(p, o); }
            Interval bound(const Box3& b) const override { return f->bound(b); }
            Box3 bounds() const override { return box; }
            bool isDistance() const override { return false; }
            std::string describe() const override { return f->describe(); }
        };
        auto bounded = std::make_shared<Bounded>();
        bounded->f = f;
        const glm::vec3 r = type == "sphere" ? glm::vec3(a) : glm::vec3(a, b, c);
        bounded->box = {-r, r};
        return bounded;
    }
    return f;
}

}  // namespace isoforge::implicit
