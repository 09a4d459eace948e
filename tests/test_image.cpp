#include <gtest/gtest.h>

#include "core/error.h"
#include "render/embree_device.h"
#include "render/image.h"
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

TEST(Embree, DeviceCreatesAndReportsVersion3) {
    auto device = render::makeDevice();
    EXPECT_NE(device.get(), nullptr);
    EXPECT_EQ(render::embreeVersion().rfind("Embree 3.", 0), 0u);
}
