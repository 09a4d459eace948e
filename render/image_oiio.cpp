// The OpenImageIO side of render/image.h, built as a module that render/image.cpp loads with
// dlopen on the first image read or written. OpenImageIO links about 260 shared libraries (codecs,
// OpenEXR, libheif, ffmpeg, ...); loading them at start-up cost every command 0.2 s, images or not.
// The module is built with the executable, by the same compiler, so C++ types cross the boundary.
#include <filesystem>

#include <OpenImageIO/imageio.h>
#include <OpenImageIO/oiioversion.h>

#include "render/image.h"
#include "render/image_module.h"

namespace {

using isoforge::render::Image;

bool writeOiio(const char* path, const char* temp, const Image& image, const float* data, bool floating,
               std::string& error) {
    OIIO::ImageSpec spec(image.width, image.height, image.channels,
                         floating ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8);
    if (!image.channelNames.empty()) spec.channelnames = image.channelNames;
    if (image.channels == 4) spec.alpha_channel = 3;
    spec.attribute("oiio:ColorSpace", floating ? "Linear" : "sRGB");
    spec.attribute("Software", "isoforge");
    auto out = OIIO::ImageOutput::create(path);
    if (!out) {
        error = "no image format for extension '" + std::filesystem::path(path).extension().string() +
                "': " + OIIO::geterror();
        return false;
    }
    if (!out->open(temp, spec) || !out->write_image(OIIO::TypeDesc::FLOAT, data) || !out->close()) {
        error = "cannot write image: " + out->geterror();
        return false;
    }
    return true;
}

bool readOiio(const char* path, Image& image, bool& floating, std::string& error) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
        error = "cannot read image: " + OIIO::geterror();
        return false;
    }
    const OIIO::ImageSpec& spec = in->spec();
    image = Image(spec.width, spec.height, spec.nchannels);
    image.channelNames = spec.channelnames;
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.pixels.data())) {
        error = "cannot read image: " + in->geterror();
        return false;
    }
    floating = spec.format.basetype == OIIO::TypeDesc::FLOAT || spec.format.basetype == OIIO::TypeDesc::HALF;
    return true;
}

const isoforge::render::ImageModule kModule{isoforge::render::kImageModuleAbi, "OpenImageIO " OIIO_VERSION_STRING,
                                            writeOiio, readOiio};

}  // namespace

extern "C" __attribute__((visibility("default"))) const isoforge::render::ImageModule* isoforge_image_module() {
    return &kModule;
}
