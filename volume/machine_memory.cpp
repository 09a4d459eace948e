#include "volume/machine_memory.h"

#include <unistd.h>

namespace isoforge::volume {

std::uint64_t physicalMemory() {
    const long pages = ::sysconf(_SC_PHYS_PAGES), size = ::sysconf(_SC_PAGE_SIZE);
    return pages > 0 && size > 0 ? static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(size)
                                 : std::uint64_t{8} << 30;
}

}  // namespace isoforge::volume
