#include "core/temporary_files.h"

#include <unistd.h>
#include <atomic>
#include <csignal>
#include <cstring>
#include <mutex>

namespace isoforge {

namespace {

// Fixed storage, so that the handler reads it without allocating or locking (async-signal-safe).
constexpr int kSlots = 32;
constexpr std::size_t kPathMax = 4096;
char paths[kSlots][kPathMax];
std::atomic<bool> used[kSlots];
static_assert(std::atomic<bool>::is_always_lock_free);

constexpr int kSignals[] = {SIGINT, SIGTERM, SIGHUP};
struct sigaction previous[3];
std::once_flag installed;

extern "C" void removeTemporaries(int sig, siginfo_t* info, void* context) {
    for (int k = 0; k < 3; ++k) {
        if (kSignals[k] != sig) continue;
        const struct sigaction& before = previous[k];
        // A program that handles the signal itself goes on (and unwinds, which removes its files).
        if (before.sa_flags & SA_SIGINFO) return before.sa_sigaction(sig, info, context);
        if (before.sa_handler == SIG_IGN) return;
        if (before.sa_handler != SIG_DFL) return before.sa_handler(sig);
    }
    // The default action ends the process: remove the files, then end by the signal as without this handler.
    for (int i = 0; i < kSlots; ++i)
        if (used[i].load(std::memory_order_acquire)) ::unlink(paths[i]);
    std::signal(sig, SIG_DFL);
    std::raise(sig);
}

void install() {
    for (int k = 0; k < 3; ++k) {
        struct sigaction action {};
        action.sa_sigaction = removeTemporaries;
        sigemptyset(&action.sa_mask);
        action.sa_flags = SA_RESTART | SA_SIGINFO;
        sigaction(kSignals[k], &action, &previous[k]);
    }
}

std::mutex slotsMutex;

}  // namespace

int removeOnSignal(const std::string& path) {
    std::call_once(installed, install);
    if (path.size() + 1 > kPathMax) return -1;
    std::lock_guard lock(slotsMutex);
    for (int i = 0; i < kSlots; ++i) {
        if (used[i].load(std::memory_order_relaxed)) continue;
        std::memcpy(paths[i], path.c_str(), path.size() + 1);
        used[i].store(true, std::memory_order_release);
        return i;
    }
    return -1;
}

void forgetTemporary(int slot) {
    if (slot < 0 || slot >= kSlots) return;
    std::lock_guard lock(slotsMutex);
    used[slot].store(false, std::memory_order_release);
}

}  // namespace isoforge
