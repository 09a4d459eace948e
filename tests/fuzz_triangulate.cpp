/// libFuzzer target for polygon-face triangulation (polyhedron faces): any loop of points must give
/// triangles whose corners are points of the loop, at most (distinct points - 2) of them, and never a
/// crash or a hang. Input: a byte for the point count, then per point three signed bytes (small
/// integers, so that collinear, repeated and coplanar points are common), then loop indices.
/// Build: cmake -DISOFORGE_FUZZ=ON with clang (see scripts/fuzz.sh).
#include <cstddef>
#include <cstdint>
#include <set>
#include <vector>

#include "mesh/triangulate.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    const std::size_t n = std::size_t(data[0]) + 1;
    if (size < 1 + 3 * n) return 0;
    std::vector<glm::vec3> points;
    for (std::size_t i = 0; i < n; ++i) {
        const auto* p = data + 1 + 3 * i;
        points.emplace_back(float(std::int8_t(p[0])), float(std::int8_t(p[1])), float(std::int8_t(p[2])) * 0.25f);
    }
    std::vector<int> loop;
    for (std::size_t i = 1 + 3 * n; i < size; ++i) loop.push_back(int(data[i] % n));
    const auto tris = isoforge::mesh::triangulateFace(points, loop);
    const std::set<int> corners(loop.begin(), loop.end());
    if (tris.size() + 2 > loop.size() && !tris.empty()) __builtin_trap();
    for (const auto& t : tris)
        for (int k = 0; k < 3; ++k)
            if (!corners.count(int(t[k]))) __builtin_trap();
    return 0;
}
