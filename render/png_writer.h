#pragma once
/// @file 8-bit PNG written straight through libpng: the format most renders and slices go to, without
/// loading OpenImageIO's 260 libraries (0.35-0.4 s of every image command here; render/image_oiio.cpp).

#include <filesystem>
#include <string>

#include "render/image.h"

namespace isoforge::render::detail {

/// Writes `image`'s size and channel count (1 grey, 2 grey + alpha, 3 RGB, 4 RGBA) with the already
/// sRGB-encoded values `encoded` (0..1, rounded to 0..255 and premultiplied colours divided by alpha, as
/// OpenImageIO does both: the same samples whichever library writes them) to `file`, with an
/// sRGB chunk. False with `error` set on failure (the caller removes the file).
bool writePng(const std::filesystem::path& file, const Image& image, const float* encoded, std::string& error);

}  // namespace isoforge::render::detail
