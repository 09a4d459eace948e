#include "volume/machine_memory.h"

#include <sys/resource.h>
#include <unistd.h>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

namespace isoforge::volume {

std::uint64_t physicalMemory() {
    const long pages = ::sysconf(_SC_PHYS_PAGES), size = ::sysconf(_SC_PAGE_SIZE);
    return pages > 0 && size > 0 ? static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(size)
                                 : std::uint64_t{8} << 30;
}

std::uint64_t residentMemory() {
    std::FILE* f = std::fopen("/proc/self/statm", "r");
    if (!f) return 0;
    unsigned long long size = 0, resident = 0;
    const int n = std::fscanf(f, "%llu %llu", &size, &resident);
    std::fclose(f);
    const long page = ::sysconf(_SC_PAGE_SIZE);
    return n == 2 && page > 0 ? resident * static_cast<std::uint64_t>(page) : 0;
}

std::uint64_t peakResidentMemory() {
    rusage u{};
    if (::getrusage(RUSAGE_SELF, &u) != 0) return 0;
    return static_cast<std::uint64_t>(u.ru_maxrss) * 1024;  // Linux: kibibytes
}

std::uint64_t parseByteSize(const std::string& text) {
    const char* s = text.c_str();
    char* end = nullptr;
    const double v = std::strtod(s, &end);
    if (end == s || !std::isfinite(v) || v <= 0)
        throw std::invalid_argument("expected a size such as 4G, got '" + text + "'");
    std::string unit(end);
    for (char& c : unit) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    double scale = 1;
    if (!unit.empty() && unit != "B") {
        const std::string units = "KMGT";
        const auto k = units.find(unit[0]);
        const std::string rest = unit.substr(1);
        if (k == std::string::npos || !(rest.empty() || rest == "B" || rest == "IB"))
            throw std::invalid_argument("expected a size such as 512M or 4G, got '" + text + "'");
        scale = std::pow(1024.0, static_cast<double>(k + 1));
    }
    const double bytes = v * scale;
    if (bytes < 1 || bytes > 1.8e19) throw std::invalid_argument("size out of range: '" + text + "'");
    return static_cast<std::uint64_t>(bytes);
}

}  // namespace isoforge::volume
