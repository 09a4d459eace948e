#include "render/image.h"

#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <mutex>

#include "core/error.h"
#include "core/module.h"
#include "render/image_module.h"
#include "render/png_writer.h"

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

const ImageModule& loadModule() {
    using Entry = const ImageModule* (*)();
    auto entry = reinterpret_cast<Entry>(
        moduleEntry(kModuleFile, "isoforge_image_module", "it reads and writes images through OpenImageIO"));
    const ImageModule* module = entry();
    if (!module || module->abi != kImageModuleAbi)
        throw IoError(std::string(kModuleFile) + " is not a module of this isoforge build");
    return *module;
}

}  // namespace

const ImageModule& imageModule() {
    static std::once_flag once;
    static const ImageModule* module = nullptr;
    std::call_once(once, [] { module = &loadModule(); });
    return *module;
}

void writeImage(const std::filesystem::path& path, const Image& image) {
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
    // PNG straight through libpng (render/png_writer.h); every other format through OpenImageIO.
    const bool written = ext == ".png" && image.channels >= 1 && image.channels <= 4
                             ? detail::writePng(temp, image, data, error)
                             : imageModule().write(path.c_str(), temp.c_str(), image, data, floating, error);
    if (!written) {
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
