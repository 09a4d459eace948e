#include "render/image.h"

#include <unistd.h>
#include <algorithm>
#include <cmath>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>

#include "core/error.h"

namespace isoforge::render {

namespace {
bool isFloatFormat(const std::string& ext) {
    return ext == ".exr" || ext == ".hdr";
}
std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}
}  // namespace

void writeImage(const std::filesystem::path& path, const Image& image) {
    const std::string ext = lower(path.extension().string());
    const bool floating = isFloatFormat(ext);
    OIIO::ImageSpec spec(image.width, image.height, image.channels,
                         floating ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8);
    if (!image.channelNames.empty()) spec.channelnames = image.channelNames;
    if (image.channels == 4) spec.alpha_channel = 3;
    spec.attribute("oiio:ColorSpace", floating ? "Linear" : "sRGB");
    spec.attribute("Software", "isoforge");

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
    auto out = OIIO::ImageOutput::create(path.string());
    if (!out) throw IoError(path.string() + ": no image format for extension '" + ext + "': " + OIIO::geterror());
    if (!out->open(temp.string(), spec) || !out->write_image(OIIO::TypeDesc::FLOAT, data) || !out->close()) {
        std::string err = out->geterror();
        std::error_code ec;
        std::filesystem::remove(temp, ec);
        throw IoError(path.string() + ": cannot write image: " + err);
    }
    std::error_code ec;
    std::filesystem::rename(temp, path, ec);
    if (ec) {
        std::filesystem::remove(temp, ec);
        throw IoError(path.string() + ": cannot rename temporary image onto it: " + ec.message());
    }
}

Image readImage(const std::filesystem::path& path) {
    auto in = OIIO::ImageInput::open(path.string());
    if (!in) throw IoError(path.string() + ": cannot read image: " + OIIO::geterror());
    const OIIO::ImageSpec& spec = in->spec();
    Image img(spec.width, spec.height, spec.nchannels);
    img.channelNames = spec.channelnames;
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, img.pixels.data()))
        throw IoError(path.string() + ": cannot read image: " + in->geterror());
    const bool floating = spec.format.basetype == OIIO::TypeDesc::FLOAT || spec.format.basetype == OIIO::TypeDesc::HALF;
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

}  // namespace isoforge::render
