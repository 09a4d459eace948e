#include "render/image.h"

#include <dlfcn.h>
#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <mutex>

#include "core/error.h"
#include "render/image_module.h"

namespace isoforge::render {

namespace {

constexpr const char* kModuleFile = "libisoforge_image_oiio.so";

bool isFloatFormat(const std::string& ext) {
    return ext == ".exr" || ext == ".hdr";
}
std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

/// The file this code was linked into: the executable, or a shared library holding it (Python's module).
std::filesystem::path thisObject() {
    Dl_info info{};
    if (dladdr(reinterpret_cast<void*>(&thisObject), &info) && info.dli_fname && info.dli_fname[0] == '/')
        return info.dli_fname;
    std::error_code ec;
    return std::filesystem::read_symlink("/proc/self/exe", ec);
}

/// Where the module may be: ../lib/isoforge beside the binary (the build tree's layout and the
/// installed one: bin/isoforge and lib/isoforge/), then the build tree and install prefix compiled in.
std::vector<std::filesystem::path> moduleCandidates() {
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
    for (auto& d : dirs) d /= kModuleFile;
    return dirs;
}

const ImageModule& loadModule() {
    std::string tried;
    for (const auto& candidate : moduleCandidates()) {
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
        using Entry = const ImageModule* (*)();
        auto entry = reinterpret_cast<Entry>(dlsym(handle, "isoforge_image_module"));
        const ImageModule* module = entry ? entry() : nullptr;
        if (module && module->abi == kImageModuleAbi) return *module;  // kept loaded for the process's life
        tried += "\n  " + candidate.lexically_normal().string() + ": not a module of this isoforge build";
        dlclose(handle);
    }
    throw IoError(std::string("cannot load isoforge's image module (") + kModuleFile +
                  ", which reads and writes images through OpenImageIO); looked in:" + tried);
}

}  // namespace

const ImageModule& imageModule() {
    static std::once_flag once;
    static const ImageModule* module = nullptr;
    std::call_once(once, [] { module = &loadModule(); });
    return *module;
}

void writeImage(const std::filesystem::path& path, const Image& image) {
    const ImageModule& module = imageModule();
    const std::string ext = lower(path.extension().string());
    const bool floating = isFloatFormat(ext);
    std::vector<float> encoded;
    const float* data = image.pixels.data();
    if (!floating) {
        encoded = image.pixels;
        const int colour = std::min(image.channels, 3);
        for (std::size_t i = 0; i < encoded.size(); ++i) {
            if (static_cast<int>(i % image.channels) >= colour) continue;  // alpha stays linear
            float v = std::clamp(encoded[i], 0.f, 1.f);
            encoded[i] = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
        }
        data = encoded.data();
    }

    std::filesystem::path dir = path.parent_path();
    if (dir.empty()) dir = ".";
    const std::filesystem::path temp =
        dir / ("." + path.stem().string() + ".tmp" + std::to_string(::getpid()) + path.extension().string());
    std::string error;
    if (!module.write(path.c_str(), temp.c_str(), image, data, floating, error)) {
        std::error_code ec;
        std::filesystem::remove(temp, ec);
        throw IoError(path.string() + ": " + error);
    }
    std::error_code ec;
    std::filesystem::rename(temp, path, ec);
    if (ec) {
        std::filesystem::remove(temp, ec);
        throw IoError(path.string() + ": cannot rename temporary image onto it: " + ec.message());
    }
}

Image readImage(const std::filesystem::path& path) {
    Image img;
    bool floating = false;
    std::string error;
    if (!imageModule().read(path.c_str(), img, floating, error)) throw IoError(path.string() + ": " + error);
    if (!floating) {
        const int colour = std::min(img.channels, 3);
        for (std::size_t i = 0; i < img.pixels.size(); ++i) {
            if (static_cast<int>(i % img.channels) >= colour) continue;
            float v = img.pixels[i];
            img.pixels[i] = v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
        }
    }
    return img;
}

std::string imageLibraryVersion() {
    return imageModule().version;
}

}  // namespace isoforge::render
