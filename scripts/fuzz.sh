#!/usr/bin/env bash
# Builds the fuzz targets with clang (libFuzzer + ASan + UBSan) into build-fuzz/ and runs them for a
# bounded time: the scene parser on a corpus seeded from the examples, the OpenSCAD exports (ours and,
# where installed, every 3D model of openscad-testing-data exported by openscad) and the docs; then
# polyhedron-face triangulation for a third of that time.
# Usage: scripts/fuzz.sh [SECONDS]   (default 60). Exit status non-zero on any crash, leak or hang.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
source scripts/fuzz_tree.sh
configure_fuzz_tree
cmake --build build-fuzz --target fuzz_scene fuzz_triangulate
corpus=build-fuzz/corpus
mkdir -p "$corpus"
cp examples/*.isf tests/data/openscad/*.csg "$corpus"/ 2>/dev/null || true
# The .scad -> .csg path: OpenSCAD's exports of its own regression models (those the corpus test made).
for f in build/openscad-corpus/*.csg build/openscad-corpus-fast/*.csg; do [ -f "$f" ] && cp "$f" "$corpus"/; done
awk -v dir="$corpus" '/^```scad/ { n++; f = sprintf("%s/doc%02d.isf", dir, n); inside = 1; next }
    /^```/ { inside = 0; next } inside { print >> f }' docs/scene-language.md
# intercept_tls_get_addr=0: see scripts/test.sh (a GCC <= 13 runtime flake with dlopen'ed modules).
export ASAN_OPTIONS=detect_leaks=1:fast_unwind_on_malloc=0:intercept_tls_get_addr=0
export LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp
# Bounded: total time, input length, per-input time and memory.
build-fuzz/fuzz_scene "$corpus" -max_total_time="$seconds" -max_len=4096 -timeout=10 -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix=build-fuzz/ 2>&1 | tail -25
mkdir -p build-fuzz/corpus-triangulate
build-fuzz/fuzz_triangulate build-fuzz/corpus-triangulate -max_total_time=$(( (seconds + 2) / 3 )) -max_len=2048 \
    -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix=build-fuzz/ 2>&1 | tail -12
