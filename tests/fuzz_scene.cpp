/// libFuzzer target for the scene parser and evaluator: any input must give a scene or a
/// ParseError/IoError, never a crash, a hang or unbounded memory.
/// Build: cmake -DISOFORGE_FUZZ=ON with clang (see scripts/fuzz.sh).
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string_view>

#include "core/error.h"
#include "csg/scene.h"

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
