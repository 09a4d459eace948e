#pragma once
/// @file Progress reporting and cancellation, polled by long operations per block or tile
/// (never per voxel). Implementations must be thread-safe: update() is called from worker threads.

#include <atomic>
#include <chrono>
#include <cstdio>
#include <string>

namespace isoforge {

class Progress {
public:
    virtual ~Progress() = default;
    /// A new stage of work begins (e.g. "meshing"). May throw to cancel the work.
    virtual void begin(const std::string& stage) = 0;
    /// `done` of `total` units of the current stage are finished.
    /// May throw to cancel the work (it unwinds through TBB to the caller).
    virtual void update(std::size_t done, std::size_t total) = 0;
    /// The stage is over. Must not throw: it is called from destructors, also while a cancellation unwinds.
    virtual void end() = 0;
};

/// A one-line progress bar on a terminal (stderr), redrawn at most ten times a second.
/// Does nothing when stderr is not a terminal.
class TerminalProgress final : public Progress {
public:
    TerminalProgress();
    void begin(const std::string& stage) override;
    void update(std::size_t done, std::size_t total) override;
    void end() override;
    bool enabled() const { return enabled_; }

private:
    bool enabled_ = false;
    std::string stage_;
    std::atomic<long long> lastDrawMs_{0};
    std::chrono::steady_clock::time_point start_;
};

}  // namespace isoforge
