#!/usr/bin/env bash
# Builds and runs every test.
#   scripts/test.sh             Release build in build/, all tests
#   scripts/test.sh --sanitize  AddressSanitizer + UBSan build in build-asan/, all tests
set -euo pipefail
cd "$(dirname "$0")/.."
dir=build
args=(-DCMAKE_BUILD_TYPE=Release)
if [ "${1:-}" = "--sanitize" ]; then
  dir=build-asan
  # -O1 -g1 (line tables: all that sanitizer stack traces need) instead of RelWithDebInfo's -O2 -g compiles
  # the heaviest files in half the time (render/grid_march.cpp 98 -> 48 s, tests/test_renderers.cpp 85 -> 47 s).
  args=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" -DISOFORGE_SANITIZE=ON
        -DISOFORGE_BUILD_BENCH=OFF)
  # The default (fast, frame-pointer) unwinder for malloc stacks: the slow one tripled every process's cost
  # (1.4 s instead of 0.44 s for `isoforge --help`), and the suppressions below match with either.
  # intercept_tls_get_addr=0: up to GCC 13 the runtime's __tls_get_addr interceptor takes a dynamic TLS block
  # that happens to start 16 bytes into a page for a pre-2.25 glibc header and reads the two words before it;
  # LeakSanitizer's tracer then dies at exit ("Tracer caught signal 11", exit 134) in a process that has
  # dlopen'ed a module with TLS (our OpenImageIO module): a flake of the runtime, seen once in the CLI test.
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:intercept_tls_get_addr=0
  export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  export LSAN_OPTIONS="suppressions=$PWD/tests/lsan.supp:print_suppressions=0"
fi
if [ "${CI:-}" = true ]; then args+=(-DISOFORGE_WERROR=ON); fi
cmake -S . -B "$dir" -G Ninja "${args[@]}" >/dev/null
cmake --build "$dir"
cd "$dir"
ctest --output-on-failure -j2 --timeout 600
