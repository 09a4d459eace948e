#include "core/progress.h"

#include <unistd.h>

namespace isoforge {

TerminalProgress::TerminalProgress() : enabled_(::isatty(STDERR_FILENO) == 1) {}

void TerminalProgress::begin(const std::string& stage) {
    stage_ = stage;
    start_ = std::chrono::steady_clock::now();
    lastDrawMs_ = 0;
}

void TerminalProgress::update(std::size_t done, std::size_t total) {
    if (!enabled_ || total == 0) return;
    auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - start_).count();
    long long last = lastDrawMs_.load(std::memory_order_relaxed);
    if (ms - last < 100 || !lastDrawMs_.compare_exchange_strong(last, ms)) return;
    int pct = static_cast<int>(100.0 * static_cast<double>(done) / static_cast<double>(total));
    int bars = pct / 4;
    std::fprintf(stderr, "\r%-12s [%-25.*s] %3d%%", stage_.c_str(), bars, "#########################", pct);
    std::fflush(stderr);
}

void TerminalProgress::end() {
    if (enabled_ && lastDrawMs_ > 0) std::fprintf(stderr, "\r%*s\r", 50, "");
}

}  // namespace isoforge
