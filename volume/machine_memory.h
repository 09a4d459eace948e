#pragma once
/// @file This machine's memory, against which absurd requests are refused with an estimate.
#include <cstdint>

namespace isoforge::volume {

/// Physical memory of this machine, bytes (8 GiB where the system does not say).
std::uint64_t physicalMemory();

}  // namespace isoforge::volume
