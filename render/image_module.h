#pragma once
/// @file The interface between render/image.cpp and the OpenImageIO module it loads on demand
/// (render/image_oiio.cpp). Internal to render/.

#include <string>

#include "render/image.h"

namespace isoforge::render {

/// Bumped whenever ImageModule changes, so that a stale module is refused rather than called.
inline constexpr int kImageModuleAbi = 1;

/// What the module's one exported function, `isoforge_image_module`, returns.
struct ImageModule {
    int abi;
    const char* version;  ///< "OpenImageIO 2.4.7"
    /// Writes `data` (image's size and channels; sRGB-encoded unless `floating`) to `temp` in the
    /// format `path`'s extension names. False with `error` set on failure.
    bool (*write)(const char* path, const char* temp, const Image& image, const float* data, bool floating,
                  std::string& error);
    /// Reads `path` into `image` as float values as stored; `floating` tells whether the file held floats.
    bool (*read)(const char* path, Image& image, bool& floating, std::string& error);
};

/// The loaded module (loaded on the first call; later calls return the same one).
/// @throw IoError naming where it looked when the module cannot be loaded.
const ImageModule& imageModule();

}  // namespace isoforge::render
