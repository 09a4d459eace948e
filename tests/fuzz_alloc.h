#pragma once
/// @file For libFuzzer targets whose readers meet allocation failure as release builds do: operator new
/// throws std::bad_alloc when malloc fails (AddressSanitizer's own operator new ends the process instead)
/// or when a request passes allocationLimit(), the bound a helper program's address-space limit puts on
/// the library in isoforge (core/isolate.h). Include in exactly one file of a target: it replaces the
/// global operators new and delete.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <new>

// allocator_may_return_null: malloc answers NULL and the operator throws; alloc_dealloc_mismatch=0: what
// the replaced operator new hands out is malloc's, whichever delete frees it.
extern "C" const char* __asan_default_options() {
    return "allocator_may_return_null=1:alloc_dealloc_mismatch=0";
}

namespace isoforge::fuzz {
/// The largest single request operator new grants (no bound by default).
inline std::size_t& allocationLimit() {
    static std::size_t limit = std::numeric_limits<std::size_t>::max();
    return limit;
}
inline void* allocate(std::size_t n) {
    if (n <= allocationLimit())
        if (void* p = std::malloc(n ? n : 1)) return p;
    throw std::bad_alloc();
}
}  // namespace isoforge::fuzz

void* operator new(std::size_t n) {
    return isoforge::fuzz::allocate(n);
}
void* operator new[](std::size_t n) {
    return isoforge::fuzz::allocate(n);
}
void operator delete(void* p) noexcept {
    std::free(p);
}
void operator delete[](void* p) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
    std::free(p);
}
