/// libFuzzer target for the expression parser (--expr, implicit()) and the .vm tape reader: the first byte
/// picks which, the rest is the text. Any input must give a tape that evaluates (points and intervals) or a
/// ParseError with its position; never a crash, a hang or unbounded memory.
/// Build: cmake -DISOFORGE_FUZZ=ON with clang (see scripts/fuzz.sh).
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string_view>

#include "core/error.h"
#include "implicit/tape.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
    try {
        const auto tape =
            data[0] % 2 ? isoforge::implicit::parseVm(text, "fuzz.vm") : isoforge::implicit::parseExpression(text);
        (void)tape->eval(glm::vec3(0.25f, -0.5f, 0.75f));
        const isoforge::implicit::Box3 box{glm::vec3(-1.f, -0.5f, 0.f), glm::vec3(0.5f, 1.f, 2.f)};
        (void)tape->eval(box);
        if (const auto pruned = tape->simplify(box)) (void)pruned->eval(box.centre());
    } catch (const isoforge::IoError&) {
    } catch (const std::invalid_argument&) {
    }
    return 0;
}
