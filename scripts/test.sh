#!/usr/bin/env bash
# Builds and runs every test.
#   scripts/test.sh                   Release build in build/, all tests
#   scripts/test.sh --sanitize        AddressSanitizer + UBSan build (g++) in build-asan/, all tests: the full
#                                     sanitizer run, made before an issue is resolved (about 30 minutes here)
#   scripts/test.sh --sanitize-quick  CI's sanitizer pass: the clang tree that scripts/fuzz.sh fuzzes in
#                                     (build-fuzz/: ASan + UBSan + libFuzzer's coverage), the unit tests of the
#                                     parsers, readers and geometry (test_csg, test_mesh, test_implicit,
#                                     test_volume, test_volumes, less their slowest tests) and of isoforge
#                                     view's watcher and builder (test_view) under it; the libraries compile
#                                     once for both
#   scripts/test.sh --tsan            ThreadSanitizer (clang) in build-tsan/: the thread-count determinism tests
#                                     and the parallel meshing and sampling tests (TSAN_TESTS=REGEX for others)
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-}
# intercept_tls_get_addr=0: up to GCC 13 (and LLVM 16) the runtime's __tls_get_addr interceptor takes a
# dynamic TLS block that happens to start 16 bytes into a page for a pre-2.25 glibc header and reads the two
# words before it; LeakSanitizer's tracer then dies at exit ("Tracer caught signal 11", exit 134) in a
# process that has dlopen'ed a module with TLS (our OpenImageIO module): a flake of the runtime.
# The default (fast, frame-pointer) unwinder for malloc stacks: the slow one tripled every process's cost
# (1.4 s instead of 0.44 s for `isoforge --help`), and the suppressions below match with either.
sanitizer_env() {
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:intercept_tls_get_addr=0
  export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  export LSAN_OPTIONS="suppressions=$PWD/tests/lsan.supp:print_suppressions=0"
}
if [ "$mode" = "--sanitize-quick" ]; then
  source scripts/fuzz_tree.sh
  configure_fuzz_tree
  suites=(test_csg test_mesh test_implicit test_volume test_volumes test_view)
  cmake --build build-fuzz --target "${suites[@]}"
  sanitizer_env
  cd build-fuzz
  labels=$(IFS='|'; echo "${suites[*]}")
  # The tests that take over 20 s each under the sanitizers here (846 of 1,032 s; the full run has them):
  # meshing the whole AAL atlas, real OpenSCAD exports and analytic volumes at fine voxels, fog volumes at
  # many iso-values, the self-intersection checks of the sharp-feature and simplification tests.
  slow=(Volumes.AalLabelSurfaces Scene.RealOpenScadExports Csg.VolumesOfBooleans OpenScad.FacetedPrimitives
        Scene.ExtrusionsTwistScale MarchingCubes.FogVolumes Scene.MeshAndVolumeStatements MarchingCubes.RandomNoise
        MarchingCubes.SmokeFogVolume OpenScad.PolyhedraWithConcaveFaces Simplify.FewerTriangles
        Sharp.FeatureVerticesKeep Loop.Converges OpenScad.FlippedAndOpenPolyhedra
        SlabsOfVolumes.AFileStreamedInPasses NearLevel.AStreamedGridIsTheGrid)
  skip=$(IFS='|'; echo "${slow[*]}")
  ctest --output-on-failure -j2 --timeout 600 -L "^(${labels})\$" -E "^(${skip})"
  exit
fi
if [ "$mode" = "--tsan" ]; then
  # The determinism claim's race check: the tests that compare results across thread counts (marching
  # cubes, sampling, --sharp with --max-error, rendering) and the marching-cubes and sampling suites, built
  # by clang with ThreadSanitizer in build-tsan/, on a oneTBB of Debian's version (2021.8) built with
  # ThreadSanitizer too: Debian's libtbb is not instrumented, so TSan cannot see a task handed to another
  # thread, and every parallel_for reads as a race. TBB_SOURCE=DIR: oneTBB's sources (else a shallow clone
  # of its v2021.8.0 tag). tests/tsan.supp holds what is left of TBB's and OpenVDB's own.
  tbb=build-tsan/onetbb
  if [ ! -f "$tbb/lib/libtbb.so.12" ]; then
    src=${TBB_SOURCE:-build-tsan/onetbb-src}
    [ -d "$src" ] || git clone -q --depth 1 --branch v2021.8.0 https://github.com/oneapi-src/oneTBB.git "$src"
    CXX=clang++ CC=clang cmake -S "$src" -B build-tsan/onetbb-build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
        -DTBB_SANITIZE=thread -DTBB_TEST=OFF -DTBB_EXAMPLES=OFF -DTBB_STRICT=OFF >/dev/null
    cmake --build build-tsan/onetbb-build --target tbb
    mkdir -p "$tbb/lib"
    cp -a build-tsan/onetbb-build/*_relwithdebinfo/libtbb.so* "$tbb/lib/"
  fi
  CXX=clang++ CC=clang cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" -DISOFORGE_TSAN=ON -DISOFORGE_BUILD_BENCH=OFF >/dev/null
  suites=(test_volume test_sample test_csg test_render)
  cmake --build build-tsan --target "${suites[@]}"
  export LD_LIBRARY_PATH="$PWD/$tbb/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/tests/tsan.supp"
  cd build-tsan
  ctest --output-on-failure -j1 --timeout 900 -R "${TSAN_TESTS:-WhateverTheThreadCount|MarchingCubes\.|Sample\.}"
  exit
fi
dir=build
args=(-DCMAKE_BUILD_TYPE=Release)
if [ "$mode" = "--sanitize" ]; then
  dir=build-asan
  # -O1 -g1 (line tables: all that sanitizer stack traces need) instead of RelWithDebInfo's -O2 -g compiles
  # the heaviest files in half the time (render/grid_march.cpp 98 -> 48 s, tests/test_renderers.cpp 85 -> 47 s).
  args=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" -DISOFORGE_SANITIZE=ON
        -DISOFORGE_BUILD_BENCH=OFF)
  sanitizer_env
elif [ -n "$mode" ]; then
  echo "usage: scripts/test.sh [--sanitize | --sanitize-quick | --tsan]" >&2
  exit 2
fi
if [ "${CI:-}" = true ]; then args+=(-DISOFORGE_WERROR=ON); fi
cmake -S . -B "$dir" -G Ninja "${args[@]}" >/dev/null
cmake --build "$dir"
cd "$dir"
ctest --output-on-failure -j2 --timeout 600
