/// libFuzzer target for the mesh readers: the first byte picks the format (PLY, OBJ, STL, OFF), the rest is
/// the file. Any input must give a mesh whose triangles name its vertices, or an IoError (ParseError,
/// ResourceError) naming the file; never a crash, a hang or an allocation the file cannot justify.
/// Build: cmake -DISOFORGE_FUZZ=ON with clang (see scripts/fuzz.sh).
#include <cstddef>
#include <cstdint>

#include "core/error.h"
#include "fuzz_file.h"
#include "mesh/io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    static const char* const extensions[] = {".ply", ".obj", ".stl", ".off"};
    const auto path = isoforge::fuzz::scratchFile(data + 1, size - 1, extensions[data[0] % 4]);
    try {
        const isoforge::mesh::TriMesh m = isoforge::mesh::readMesh(path);
        for (const auto& t : m.triangles)
            if (t.x >= m.positions.size() || t.y >= m.positions.size() || t.z >= m.positions.size()) __builtin_trap();
        if (!m.normals.empty() && m.normals.size() != m.positions.size()) __builtin_trap();
        if (!m.colors.empty() && m.colors.size() != m.positions.size()) __builtin_trap();
    } catch (const isoforge::IoError&) {
    } catch (const isoforge::ResourceError&) {
    }
    return 0;
}
