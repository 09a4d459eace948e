#include "render/embree_device.h"

#include <stdexcept>

#include <embree3/rtcore.h>

namespace isoforge::render {

void DeviceRelease::operator()(RTCDevice d) const {
    if (d) rtcReleaseDevice(d);
}

DevicePtr makeDevice(const std::string& config) {
    RTCDevice d = rtcNewDevice(config.empty() ? nullptr : config.c_str());
    if (!d)
        throw std::runtime_error("cannot create an Embree device (error " + std::to_string(rtcGetDeviceError(nullptr)) +
                                 ")");
    return DevicePtr(d);
}

std::string embreeVersion() {
    DevicePtr d = makeDevice();
    const auto v = rtcGetDeviceProperty(d.get(), RTC_DEVICE_PROPERTY_VERSION);
    return "Embree " + std::to_string(v / 10000) + "." + std::to_string((v / 100) % 100) + "." +
           std::to_string(v % 100);
}

}  // namespace isoforge::render
