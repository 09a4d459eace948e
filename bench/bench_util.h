#pragma once
// Timing helpers for the side-by-side benchmarks: alternate the contenders, report medians.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

namespace isoforge::bench {

/// A benchmark's command line: -h/--help prints `usage` and exits 0. Anything else that is not one
/// of `flags`, one of `valued` (which take the next argument) or, where `positional`, one input file,
/// is refused with the usage and exit status 2: a mistyped option must not start minutes of work.
inline void checkArguments(int argc, char** argv, const char* usage, std::initializer_list<std::string_view> flags,
                           std::initializer_list<std::string_view> valued = {}, bool positional = false) {
    int files = 0;
    for (int i = 1; i < argc; ++i) {
        const std::string_view a = argv[i];
        auto among = [&](std::initializer_list<std::string_view> l) {
            return std::find(l.begin(), l.end(), a) != l.end();
        };
        if (a == "-h" || a == "--help") {
            std::printf("%s\n", usage);
            std::exit(0);
        }
        if (among(flags)) continue;
        if (among(valued) && i + 1 < argc) {
            ++i;
            continue;
        }
        if (positional && !a.starts_with("-") && files++ == 0) continue;
        std::fprintf(stderr, "%s: unexpected argument '%s'\n%s\n", argv[0], argv[i], usage);
        std::exit(2);
    }
}

inline double now() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct Samples {
    std::vector<double> seconds;
    double median() const {
        auto s = seconds;
        std::sort(s.begin(), s.end());
        return s.empty() ? 0 : (s.size() % 2 ? s[s.size() / 2] : 0.5 * (s[s.size() / 2 - 1] + s[s.size() / 2]));
    }
    double min() const { return *std::min_element(seconds.begin(), seconds.end()); }
    double max() const { return *std::max_element(seconds.begin(), seconds.end()); }
};

/// Resident set size and its high-water mark in bytes, from /proc/self/status.
inline long long procStatusBytes(const char* key) {
    std::ifstream in("/proc/self/status");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind(key, 0) == 0) return std::stoll(line.substr(std::string(key).size())) * 1024;
    return -1;
}
/// Resets the high-water mark (Linux >= 4.0) so that the next peak belongs to the next call.
inline void resetPeak() {
    std::ofstream("/proc/self/clear_refs") << "5";
}
/// Runs f, returns (seconds, peak extra resident bytes during it).
template <class F>
std::pair<double, long long> timed(F&& f) {
    resetPeak();
    const long long before = procStatusBytes("VmRSS:");
    const double t0 = now();
    f();
    const double t = now() - t0;
    return {t, procStatusBytes("VmHWM:") - before};
}

}  // namespace isoforge::bench
