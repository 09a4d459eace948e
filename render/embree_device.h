#pragma once
/// @file RAII ownership of Embree handles, shared by the renderers.

#include <memory>
#include <string>

typedef struct RTCDeviceTy* RTCDevice;

namespace isoforge::render {

struct DeviceRelease {
    void operator()(RTCDevice d) const;
};
using DevicePtr = std::unique_ptr<std::remove_pointer_t<RTCDevice>, DeviceRelease>;

/// Creates an Embree device (following TBB's thread limit).
/// @throw std::runtime_error with Embree's error text if it cannot be created.
DevicePtr makeDevice(const std::string& config = "");

/// "Embree 3.13.5", as the linked library reports it.
std::string embreeVersion();

}  // namespace isoforge::render
