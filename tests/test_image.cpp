#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>

#include <png.h>

#include <gtest/gtest.h>

#include "core/error.h"
#include "render/embree_device.h"
#include "render/image.h"
#include "render/image_module.h"
#include "test_util.h"

using namespace isoforge;

TEST(Image, PngAndExrRoundTripWithSrgbEncoding) {
    const auto dir = test::scratchDir("image");
    render::Image img(16, 8, 3);
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 16; ++x) {
            float* p = img.at(x, y);
            p[0] = x / 15.f;
            p[1] = y / 7.f;
            p[2] = 0.5f;
        }
    render::writeImage(dir / "a.png", img);
    render::writeImage(dir / "a.exr", img);
    const auto png = render::readImage(dir / "a.png");
    const auto exr = render::readImage(dir / "a.exr");
    ASSERT_EQ(png.width, 16);
    ASSERT_EQ(png.height, 8);
    for (std::size_t i = 0; i < img.pixels.size(); ++i) {
        EXPECT_NEAR(exr.pixels[i], img.pixels[i], 1e-6f);
        EXPECT_NEAR(png.pixels[i], img.pixels[i], 0.01f);  // 8-bit sRGB quantization
    }
    EXPECT_THROW(render::writeImage(dir / "a.unknownformat", img), IoError);
    EXPECT_THROW(render::writeImage(dir / "no/dir/a.png", img), IoError);
    EXPECT_THROW(render::readImage(dir / "missing.png"), IoError);
    std::filesystem::remove_all(dir);
}

namespace {
/// A PNG's samples as stored (libpng's simplified reader, no colour or alpha conversion).
std::vector<std::uint8_t> pngSamples(const std::filesystem::path& path, int& channels) {
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    EXPECT_TRUE(png_image_begin_read_from_file(&image, path.c_str())) << path;
    channels = int(PNG_IMAGE_SAMPLE_CHANNELS(image.format));
    std::vector<std::uint8_t> samples(PNG_IMAGE_SIZE(image));
    EXPECT_TRUE(png_image_finish_read(&image, nullptr, samples.data(), 0, nullptr)) << path;
    return samples;
}
}  // namespace

TEST(Image, PngThroughLibpngHoldsTheSamplesOpenImageIoWrites) {
    // PNG is written through libpng (render/png_writer.h) without loading OpenImageIO; OpenImageIO's PNG
    // writer is the reference, given the same data: the same samples for every channel count (its alpha
    // handling included), values outside 0..1 and odd sizes; an sRGB chunk; a write that fails leaves the
    // old file and no temporary.
    const auto dir = test::scratchDir("image-png");
    for (const int channels : {1, 2, 3, 4}) {
        SCOPED_TRACE(std::to_string(channels) + " channels");
        render::Image img(37, 11, channels);
        for (std::size_t i = 0; i < img.pixels.size(); ++i)
            img.pixels[i] = float(i * 7 % 301) / 280.f - 0.03f;  // below 0, past 1 and every step between
        render::writeImage(dir / "ours.png", img);
        std::string error;
        // writeImage encodes to sRGB before the writer; give OpenImageIO the same encoded values.
        render::Image encoded = img;
        for (std::size_t i = 0; i < encoded.pixels.size(); ++i) {
            if (int(i % channels) >= std::min(channels, 3)) continue;
            const float v = std::clamp(encoded.pixels[i], 0.f, 1.f);
            encoded.pixels[i] = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
        }
        ASSERT_TRUE(render::imageModule().write((dir / "oiio.png").c_str(), (dir / "oiio.png").c_str(), encoded,
                                                encoded.pixels.data(), false, error))
            << error;
        int ours = 0, theirs = 0;
        const auto a = pngSamples(dir / "ours.png", ours), b = pngSamples(dir / "oiio.png", theirs);
        EXPECT_EQ(ours, channels);
        EXPECT_EQ(theirs, channels);
        ASSERT_EQ(a.size(), b.size());
        std::size_t differ = 0;
        for (std::size_t i = 0; i < a.size(); ++i) differ += a[i] != b[i];
        EXPECT_EQ(differ, 0u);
    }
    std::ifstream in(dir / "ours.png", std::ios::binary);
    const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    EXPECT_EQ(bytes.compare(0, 8, "\x89PNG\r\n\x1a\n"), 0);
    EXPECT_NE(bytes.find("sRGB"), std::string::npos);
    // Five channels: PNG cannot hold them; the old file stays, and no temporary.
    EXPECT_THROW(render::writeImage(dir / "ours.png", render::Image(4, 4, 5)), IoError);
    EXPECT_EQ(render::readImage(dir / "ours.png").width, 37);
    std::size_t files = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++files;
    EXPECT_EQ(files, 2u);
    std::filesystem::remove_all(dir);
}

TEST(Embree, DeviceCreatesAndReportsVersion3) {
    auto device = render::makeDevice();
    EXPECT_NE(device.get(), nullptr);
    EXPECT_EQ(render::embreeVersion().rfind("Embree 3.", 0), 0u);
}
