#include "render/png_writer.h"

#include <algorithm>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <vector>

#include <png.h>

namespace isoforge::render::detail {

namespace {

struct Writer {
    png_structp png = nullptr;
    png_infop info = nullptr;
    std::FILE* file = nullptr;
    std::string message;
    ~Writer() {
        if (png) png_destroy_write_struct(&png, info ? &info : nullptr);
        if (file) std::fclose(file);
    }
};

[[noreturn]] void onError(png_structp png, png_const_charp message) {
    static_cast<Writer*>(png_get_error_ptr(png))->message = message;
    png_longjmp(png, 1);
}

void onWarning(png_structp, png_const_charp) {}

}  // namespace

bool writePng(const std::filesystem::path& path, const Image& image, const float* encoded, std::string& error) {
    static constexpr int kColourTypes[4] = {PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                            PNG_COLOR_TYPE_RGB_ALPHA};
    if (image.channels < 1 || image.channels > 4) {
        error = "PNG holds 1 to 4 channels, not " + std::to_string(image.channels);
        return false;
    }
    // Rows as bytes first: nothing below may allocate after setjmp.
    const std::size_t rowBytes = std::size_t(image.width) * std::size_t(image.channels);
    std::vector<std::uint8_t> bytes(rowBytes * std::size_t(image.height));
    for (std::size_t i = 0; i < bytes.size(); ++i)
        bytes[i] = std::uint8_t(std::clamp(encoded[i] * 255.f + 0.5f, 0.f, 255.f));
    // Our colours are premultiplied by alpha; PNG's are not. Divided as OpenImageIO's PNG writer divides
    // them (on the 8-bit samples, rounding down), so that a file is the same whichever library wrote it.
    if (image.channels == 2 || image.channels == 4) {
        const int alpha = image.channels - 1;
        for (std::size_t p = 0; p < bytes.size(); p += std::size_t(image.channels)) {
            const unsigned a = bytes[p + std::size_t(alpha)];
            if (a == 0) continue;
            for (int c = 0; c < alpha; ++c)
                bytes[p + std::size_t(c)] = std::uint8_t(std::min(255u, bytes[p + std::size_t(c)] * 255u / a));
        }
    }
    std::vector<png_bytep> rows(std::size_t(image.height));
    for (std::size_t y = 0; y < rows.size(); ++y) rows[y] = bytes.data() + y * rowBytes;

    Writer w;
    w.file = std::fopen(path.c_str(), "wb");
    if (!w.file) {
        error = "cannot write image: cannot create " + path.string();
        return false;
    }
    w.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &w, onError, onWarning);
    if (w.png) w.info = png_create_info_struct(w.png);
    if (!w.png || !w.info) {
        error = "cannot write image: libpng could not start";
        return false;
    }
    if (setjmp(png_jmpbuf(w.png))) {
        error = "cannot write image: " + w.message;
        return false;
    }
    png_init_io(w.png, w.file);
    png_set_IHDR(w.png, w.info, png_uint_32(image.width), png_uint_32(image.height), 8,
                 kColourTypes[image.channels - 1], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB(w.png, w.info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_text software{};
    software.compression = PNG_TEXT_COMPRESSION_NONE;
    software.key = const_cast<png_charp>("Software");
    software.text = const_cast<png_charp>("isoforge");
    png_set_text(w.png, w.info, &software, 1);
    png_set_rows(w.png, w.info, rows.data());
    png_write_png(w.png, w.info, PNG_TRANSFORM_IDENTITY, nullptr);
    const bool closed = std::fclose(w.file) == 0;
    w.file = nullptr;
    if (!closed) {
        error = "cannot write image: " + path.string() + ": the disk refused the data";
        return false;
    }
    return true;
}

}  // namespace isoforge::render::detail
