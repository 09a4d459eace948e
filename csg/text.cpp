#include "csg/text.h"

#include <mutex>

#include "core/module.h"
#include "csg/text_module.h"

namespace isoforge::csg {

namespace {
const TextModule& textModule() {
    static std::once_flag once;
    static const TextModule* module = nullptr;
    std::call_once(once, [] {
        using Entry = const TextModule* (*)();
        auto entry = reinterpret_cast<Entry>(moduleEntry("libisoforge_text.so", "isoforge_text_module",
                                                         "it draws text() with fontconfig, FreeType and HarfBuzz"));
        module = entry();
        if (!module || module->abi != kTextModuleAbi)
            throw std::runtime_error("libisoforge_text.so is not a module of this isoforge build");
    });
    return *module;
}
}  // namespace

Profile textProfile(const TextParams& p, std::string* fontUsed) {
    const std::vector<Profile> glyphs = textModule().glyphs(p, fontUsed);
    std::vector<const Profile*> ps;
    for (const Profile& g : glyphs) ps.push_back(&g);
    return uniteProfiles(ps);  // OpenSCAD's ClipperUtils::apply of the glyphs
}

}  // namespace isoforge::csg
