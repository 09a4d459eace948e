// Stored voxel values: their types, their conversion to float, and the size a volume of them may have. A file
// of its own so that the DICOM helper program links it without the rest of the volume library (OpenVDB).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>

#include "core/error.h"
#include "volume/machine_memory.h"
#include "volume/readers.h"

namespace isoforge::volume::detail {

void checkVolumeDims(const std::filesystem::path& path, const std::array<std::int64_t, 3>& dims) {
    for (std::int64_t d : dims)
        if (d < 1 || d > (1 << 20))
            throw IoError(path.string() + ": dimensions " + std::to_string(dims[0]) + " x " + std::to_string(dims[1]) +
                          " x " + std::to_string(dims[2]) + " are not from 1 to 1,048,576");
}

void checkVolumeSize(const std::filesystem::path& path, const std::array<std::int64_t, 3>& dims) {
    checkVolumeDims(path, dims);
    const double bytes = double(dims[0]) * double(dims[1]) * double(dims[2]) * 4.0;
    if (bytes > double(physicalMemory()) / 2)
        throw ResourceError(path.string() + ": " + std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " +
                            std::to_string(dims[2]) + " voxels would need about " +
                            std::to_string(std::llround(bytes / double(1 << 20))) +
                            " MiB as floats, more than half of this machine's memory");
}

std::size_t typeSize(const std::string& t) {
    static const std::map<std::string, std::size_t> sizes = {
        {"uint8", 1}, {"int8", 1},    {"uint16", 2},  {"int16", 2},  {"uint32", 4},
        {"int32", 4}, {"float32", 4}, {"float64", 8}, {"uint64", 8}, {"int64", 8}};
    auto it = sizes.find(t);
    return it == sizes.end() ? 0 : it->second;
}

namespace {
template <class T>
void convertTyped(const unsigned char* in, bool swap, std::size_t count, float* out) {
    for (std::size_t i = 0; i < count; ++i) {
        unsigned char b[sizeof(T)];
        std::memcpy(b, in + i * sizeof(T), sizeof(T));
        if (swap) std::reverse(b, b + sizeof(T));
        T v;
        std::memcpy(&v, b, sizeof(T));
        out[i] = static_cast<float>(v);
    }
}
}  // namespace

void convertVoxels(const void* data, const std::string& t, bool bigEndian, std::size_t count, float* out) {
    const auto* in = static_cast<const unsigned char*>(data);
    const bool swap = bigEndian != (std::endian::native == std::endian::big);
    if (t == "uint8") return convertTyped<std::uint8_t>(in, false, count, out);
    if (t == "int8") return convertTyped<std::int8_t>(in, false, count, out);
    if (t == "uint16") return convertTyped<std::uint16_t>(in, swap, count, out);
    if (t == "int16") return convertTyped<std::int16_t>(in, swap, count, out);
    if (t == "uint32") return convertTyped<std::uint32_t>(in, swap, count, out);
    if (t == "int32") return convertTyped<std::int32_t>(in, swap, count, out);
    if (t == "uint64") return convertTyped<std::uint64_t>(in, swap, count, out);
    if (t == "int64") return convertTyped<std::int64_t>(in, swap, count, out);
    if (t == "float32") return convertTyped<float>(in, swap, count, out);
    if (t == "float64") return convertTyped<double>(in, swap, count, out);
    throw std::invalid_argument("unknown voxel type " + t);
}

}  // namespace isoforge::volume::detail
