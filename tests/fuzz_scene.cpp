/// libFuzzer target for the scene parser and evaluator: any input must give a scene or a
/// ParseError/IoError, never a crash, a hang or unbounded memory.
/// Build: cmake -DISOFORGE_FUZZ=ON with clang (see scripts/fuzz.sh).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

#include <unistd.h>

#include "core/error.h"
#include "csg/parts.h"
#include "csg/profile.h"
#include "csg/scene.h"

// Scenes name files relative to the working directory: run in an empty one, so that a seed from the docs
// does not load the bundled sphere.vdb and cow.obj at every mutation (over the 10 s timeout under ASan on
// a loaded machine). The readers have fuzz targets of their own.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
    const auto dir = std::filesystem::temp_directory_path() / ("isoforge-fuzz-scene-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    std::filesystem::current_path(dir);
    // OpenSCAD's sliced extrusions cost their slice count, which one mutated digit multiplies: keep each
    // under 20,000 wall triangles (tests/data/openscad/extrude.csg has 2,400), past that the continuous twist.
    isoforge::csg::maxExtrusionTriangles() = 20000;
    // Minkowski sums the same way: a mutated $fn or a fourth child made 10^5-point hulls of 3 s each under
    // ASan, and the corpus drifted to them (22 inputs a second). The full limit is tested in test_openscad_hull.
    isoforge::csg::maxMinkowskiSums() = 20000;
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    try {
        const isoforge::csg::Scene s = isoforge::csg::parseScene(text, "fuzz.isf");
        if (!s.root) __builtin_trap();
        // Touch the field: values and bounds must not crash either.
        (void)s.root->value(glm::vec3(0.1f, 0.2f, 0.3f));
        (void)s.root->bounds();
    } catch (const isoforge::IoError&) {
    } catch (const std::invalid_argument&) {
    }
    return 0;
}
