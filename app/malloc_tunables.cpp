#include "app/malloc_tunables.h"

#include <cstdlib>

namespace isoforge::app {

std::string mallocTunablesText() {
    const char* tunables = std::getenv("GLIBC_TUNABLES");
    return tunables && *tunables ? std::string("GLIBC_TUNABLES=") + tunables
                                 : std::string("glibc's defaults (no GLIBC_TUNABLES)");
}

}  // namespace isoforge::app
