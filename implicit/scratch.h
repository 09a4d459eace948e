#pragma once
/// @file Per-thread scratch buffers for batch evaluation (Field::values), one per nesting depth.

#include <cstddef>
#include <deque>
#include <span>
#include <vector>

namespace isoforge::implicit {

/// A buffer of n elements for the duration of a node's values() call, reused across calls on the
/// same thread instead of allocated each time (a boolean's children's values, a transform's local
/// points: a tree of 220 boxes under nested groups allocated one per node per batch). Buffers are
/// stacked by nesting depth, so a node's children get buffers of their own while its buffer is live:
/// a transform under a boolean must not overwrite the values the boolean is still combining.
/// Construct and destroy in stack order (as locals); contents start unspecified.
template <class T>
class Scratch {
public:
    explicit Scratch(std::size_t n) {
        std::deque<std::vector<T>>& p = pool();  // a deque: growing it moves no buffer in use
        std::size_t& d = depth();
        if (p.size() <= d) p.resize(d + 1);
        buffer_ = &p[d];
        ++d;
        buffer_->resize(n);
    }
    ~Scratch() { --depth(); }
    Scratch(const Scratch&) = delete;
    Scratch& operator=(const Scratch&) = delete;

    std::span<T> span() { return {buffer_->data(), buffer_->size()}; }
    T& operator[](std::size_t i) { return (*buffer_)[i]; }

private:
    static std::deque<std::vector<T>>& pool() {
        thread_local std::deque<std::vector<T>> p;
        return p;
    }
    static std::size_t& depth() {
        thread_local std::size_t d = 0;
        return d;
    }
    std::vector<T>* buffer_;
};

}  // namespace isoforge::implicit
