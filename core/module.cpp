#include "core/module.h"

#include <dlfcn.h>
#include <unistd.h>

#include <filesystem>
#include <vector>

#include "core/error.h"

namespace isoforge {

namespace {

/// The file this code was linked into: the executable, or a shared library holding it (Python's module).
std::filesystem::path thisObject() {
    Dl_info info{};
    if (dladdr(reinterpret_cast<void*>(&thisObject), &info) && info.dli_fname && info.dli_fname[0] == '/')
        return info.dli_fname;
    std::error_code ec;
    return std::filesystem::read_symlink("/proc/self/exe", ec);
}

/// ../lib/isoforge beside the binary (the build tree's layout and the installed one: bin/isoforge and
/// lib/isoforge/), the binary's own directory, then the build tree and install prefix compiled in.
std::vector<std::filesystem::path> candidates(const std::string& file) {
    std::vector<std::filesystem::path> dirs;
    const std::filesystem::path self = thisObject();
    if (!self.empty()) {
        dirs.push_back(self.parent_path() / ".." / "lib" / "isoforge");
        dirs.push_back(self.parent_path());
    }
#ifdef ISOFORGE_BUILD_MODULE_DIR
    dirs.emplace_back(ISOFORGE_BUILD_MODULE_DIR);
#endif
#ifdef ISOFORGE_INSTALL_MODULE_DIR
    dirs.emplace_back(ISOFORGE_INSTALL_MODULE_DIR);
#endif
    for (auto& d : dirs) d /= file;
    return dirs;
}

}  // namespace

void* moduleEntry(const std::string& file, const char* symbol, const std::string& what) {
    std::string tried;
    for (const auto& candidate : candidates(file)) {
        std::error_code ec;
        if (!std::filesystem::exists(candidate, ec)) {
            tried += "\n  " + candidate.lexically_normal().string() + ": not there";
            continue;
        }
        void* handle = dlopen(candidate.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (!handle) {
            tried += "\n  " + candidate.lexically_normal().string() + ": " + dlerror();
            continue;
        }
        if (void* entry = dlsym(handle, symbol)) return entry;  // kept loaded for the process's life
        tried += "\n  " + candidate.lexically_normal().string() + ": no " + symbol;
        dlclose(handle);
    }
    throw IoError("cannot load isoforge's module " + file + " (" + what + "); looked in:" + tried);
}

std::filesystem::path helperProgram(const std::string& file, const std::string& what) {
    std::string tried;
    for (const auto& candidate : candidates(file)) {
        if (::access(candidate.c_str(), X_OK) == 0) return candidate.lexically_normal();
        tried += "\n  " + candidate.lexically_normal().string() + ": not there";
    }
    throw IoError("cannot find isoforge's helper " + file + " (" + what + "); looked in:" + tried);
}

}  // namespace isoforge
