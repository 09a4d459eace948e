/// libFuzzer target for the colour and name tables of label maps: the first byte picks the kind (a binary
/// .lut of 768 bytes, or a text table: ITK-SNAP, 3D Slicer, names-only), the rest is the file. Any input
/// must give a table of labels with colours in [0, 1], or an IoError naming the file and line; never a
/// crash or a hang.
/// Build: cmake -DISOFORGE_FUZZ=ON with clang (see scripts/fuzz.sh).
#include <cstddef>
#include <cstdint>

#include "core/error.h"
#include "fuzz_file.h"
#include "volume/labels.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    static const char* const extensions[] = {".lut", ".txt"};
    const auto path = isoforge::fuzz::scratchFile(data + 1, size - 1, extensions[data[0] % 2]);
    try {
        const isoforge::volume::LabelTable table = isoforge::volume::readLabelTable(path);
        for (const auto& [label, info] : table)
            for (float c : info.color)
                if (!(c >= 0.0f && c <= 1.0f)) __builtin_trap();
    } catch (const isoforge::IoError&) {
    }
    return 0;
}
