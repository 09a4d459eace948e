#pragma once
/// @file This machine's memory, against which absurd requests are refused with an estimate.
#include <cstdint>
#include <string>

namespace isoforge::volume {

/// Physical memory of this machine, bytes (8 GiB where the system does not say).
std::uint64_t physicalMemory();

}  // namespace isoforge::volume

namespace isoforge::volume {

/// This process's resident memory now, bytes (0 where the system does not say).
std::uint64_t residentMemory();
/// The most resident memory this process has had, bytes (getrusage's maximum resident set size).
std::uint64_t peakResidentMemory();

/// "512M", "4G", "1.5GiB", "800000000": bytes (suffixes K, M, G, T are powers of 1024; an optional
/// "B" or "iB" after them). @throw std::invalid_argument for anything else or a size of 0.
std::uint64_t parseByteSize(const std::string& text);

}  // namespace isoforge::volume
