/// libFuzzer target for the Bézier patch reader (.bpt, Newell's teapot format) and the tessellation of
/// what it reads. Any input must give patches whose control nets match their degrees, tessellated into a
/// mesh whose triangles name its vertices, or an IoError naming the file; never a crash, a hang, or an
/// allocation the file cannot justify (a hostile patch count or degree).
/// Build: cmake -DISOFORGE_FUZZ=ON with clang (see scripts/fuzz.sh).
#include <cstddef>
#include <cstdint>

#include "core/error.h"
#include "fuzz_file.h"
#include "mesh/parametric.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const auto path = isoforge::fuzz::scratchFile(data, size, ".bpt");
    try {
        const auto patches = isoforge::mesh::readBezierPatches(path);
        for (const auto& p : patches)
            if (p.points.size() != std::size_t(p.degreeU + 1) * std::size_t(p.degreeV + 1)) __builtin_trap();
        const isoforge::mesh::TriMesh m = isoforge::mesh::tessellate(patches, 4);
        for (const auto& t : m.triangles)
            if (t.x >= m.positions.size() || t.y >= m.positions.size() || t.z >= m.positions.size()) __builtin_trap();
    } catch (const isoforge::IoError&) {
    } catch (const isoforge::ResourceError&) {
    }
    return 0;
}
