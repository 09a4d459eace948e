# Sourced by scripts/fuzz.sh and scripts/test.sh --sanitize-quick: configures build-fuzz/, where clang
# instruments everything with ASan, UBSan and libFuzzer's coverage (ISOFORGE_FUZZ). -O1 -g1: line tables are
# all that stack traces need, and the tree compiles in about 6 minutes here.
configure_fuzz_tree() {
  CXX=clang++ CC=clang cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" -DISOFORGE_FUZZ=ON -DISOFORGE_BUILD_BENCH=OFF >/dev/null
}
