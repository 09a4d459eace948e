#include "implicit/field.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>

namespace isoforge::implicit {

Box3 Box3::everything() {
    const float inf = std::numeric_limits<float>::infinity();
    return {glm::vec3(-inf), glm::vec3(inf)};
}
bool Box3::isBounded() const {
    for (int k = 0; k < 3; ++k)
        if (!std::isfinite(min[k]) || !std::isfinite(max[k])) return false;
    return true;
}
float Box3::halfDiagonal() const {
    return 0.5f * glm::length(max - min);
}
Box3 Box3::intersect(const Box3& o) const {
    return {glm::max(min, o.min), glm::min(max, o.max)};
}
Box3 Box3::unite(const Box3& o) const {
    if (isEmpty()) return o;
    if (o.isEmpty()) return *this;
    return {glm::min(min, o.min), glm::max(max, o.max)};
}

void Field::values(std::span<const glm::vec3> p, std::span<float> out) const {
    for (std::size_t i = 0; i < p.size(); ++i) out[i] = value(p[i]);
}

glm::vec3 Field::gradient(const glm::vec3& p) const {
    const float h = std::max(1e-4f, 1e-4f * glm::length(p));
    glm::vec3 g;
    for (int k = 0; k < 3; ++k) {
        glm::vec3 a = p, b = p;
        a[k] += h;
        b[k] -= h;
        g[k] = (value(a) - value(b)) / (2.f * h);
    }
    return g;
}

float Field::valueAndGradient(const glm::vec3& p, glm::vec3& g) const {
    g = gradient(p);
    return value(p);
}

FieldPtr simplified(const FieldPtr& f, const Box3& box) {
    FieldPtr s = f->simplify(box);
    return s ? s : f;
}

}  // namespace isoforge::implicit
