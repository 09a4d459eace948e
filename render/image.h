#pragma once
/// @file Images and their output: PNG through libpng, other formats and all reading through OpenImageIO,
/// loaded on the first such image.

#include <filesystem>
#include <string>
#include <vector>

namespace isoforge::render {

/// A float image, row 0 at the top, channels interleaved, linear (not sRGB-encoded) values.
struct Image {
    int width = 0, height = 0, channels = 0;
    std::vector<float> pixels;
    std::vector<std::string> channelNames;  ///< empty: R, G, B, A as the channel count implies

    Image() = default;
    Image(int w, int h, int c) : width(w), height(h), channels(c), pixels(static_cast<std::size_t>(w) * h * c, 0.f) {}
    float* at(int x, int y) { return pixels.data() + (static_cast<std::size_t>(y) * width + x) * channels; }
    const float* at(int x, int y) const { return pixels.data() + (static_cast<std::size_t>(y) * width + x) * channels; }
};

/// Writes `image` atomically; the format follows the extension (.png .jpg .tif .exr ...); PNG without
/// loading OpenImageIO.
/// 8- and 16-bit formats get sRGB-encoded values; float formats (EXR) keep linear values.
/// @throw IoError if the format is unknown or the write fails (no partial file is left).
void writeImage(const std::filesystem::path& path, const Image& image);

/// Reads an image as linear float values (sRGB-decoded for 8/16-bit files).
/// @throw IoError naming the file on failure.
Image readImage(const std::filesystem::path& path);

/// "OpenImageIO 2.4.7": the library images go through (loads it; see render/image_module.h).
/// @throw IoError if it cannot be loaded.
std::string imageLibraryVersion();

}  // namespace isoforge::render
