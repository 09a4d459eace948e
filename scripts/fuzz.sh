#!/usr/bin/env bash
# Builds the fuzz targets with clang (libFuzzer + ASan + UBSan) into build-fuzz/ and runs each for a
# bounded time: the scene parser for SECONDS on a corpus seeded from the examples, the OpenSCAD exports
# (ours and, where installed, every 3D model of openscad-testing-data exported by openscad) and the docs;
# then, for a third of that time each, polyhedron-face triangulation, the mesh readers (PLY, OBJ, STL,
# OFF), the volume readers (NIfTI, NRRD, MetaImage), raw voxels with hostile options, DICOM series, .vdb
# files, Bézier patches (.bpt), colour tables, and the expression and .vm parsers; each seeded with the
# starts of real files and small whole ones (scripts/fuzz_seeds.py, tests/data/fuzz/seeds/).
# Usage: scripts/fuzz.sh [SECONDS [TARGET ...]]   (default 60, every target; a target is a name such as
#        scene, raw or vdb, and then runs for SECONDS). FUZZ_RUNS=N stops each target after N inputs
#        instead (the long runs of docs/reliability.md). Exit status non-zero on any crash, leak or hang.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
chosen=$#
all=(scene triangulate mesh_readers volume_readers raw dicom vdb bpt label_table expression)
targets=("${@:-${all[@]}}")
source scripts/fuzz_tree.sh
configure_fuzz_tree
cmake --build build-fuzz --target "${targets[@]/#/fuzz_}"
# intercept_tls_get_addr=0: see scripts/test.sh (a GCC <= 13 runtime flake with dlopen'ed modules). The fast
# unwinder (the default) on malloc: the slow one made CGAL-heavy seeds 15x slower (hull3-tests: 33 s, past
# the 10 s timeout on a loaded machine; 2.2 s fast), and tests/lsan.supp matches with either.
export ASAN_OPTIONS=detect_leaks=1:intercept_tls_get_addr=0
export LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp
# The scene parser gets SECONDS when every target runs, the others a third of it; chosen targets SECONDS.
third=$(( chosen ? seconds : (seconds + 2) / 3 ))
run() {  # target max_len [seconds]: bounded total time (or FUZZ_RUNS), input length, per-input time, memory
  # With batch=N, a fresh process every N inputs (targets whose library leaks on bad input, checked with
  # leak detection off: the leaks would otherwise pile up to the memory limit); the totals are summed.
  local seconds=${3:-$third} total=0 start=$SECONDS left limit status=0 out contained=
  echo "== fuzz_$1"
  while :; do
    if [ -n "${FUZZ_RUNS:-}" ]; then
      left=$(( FUZZ_RUNS - total ))
      limit="-runs=$(( ${batch:-$left} < left ? ${batch:-$left} : left ))"
    else
      limit="-max_total_time=$(( seconds - (SECONDS - start) ))${batch:+ -runs=$batch}"
    fi
    out=$(build-fuzz/fuzz_$1 "$PWD/$seeds" $limit -max_len="$2" -timeout=10 -rss_limit_mb=2048 ${flags:-} \
        -print_final_stats=1 -artifact_prefix="${artifacts:-$PWD/build-fuzz/}" 2>&1) || status=$?
    total=$(( total + $(sed -n 's/^stat::number_of_executed_units: *//p' <<< "$out" | tail -1 | grep . || echo 0) ))
    # A line per process, so that a long run stopped early still says how far it got.
    [ -n "${batch:-}" ] && echo "fuzz_$1: $total inputs in $(( SECONDS - start )) s so far"
    # A target may count what it contains ("fuzz_X: N ... (contained ...)": GDCM's assertions).
    contained=$(( ${contained:-0} + $(sed -n 's/^fuzz_[a-z_]*: \([0-9]*\) .*(contained.*/\1/p' <<< "$out" | tail -1 | grep . || echo 0) ))
    if [ -z "${batch:-}" ] || [ "$status" -ne 0 ] || { [ -n "${FUZZ_RUNS:-}" ] && [ "$total" -ge "$FUZZ_RUNS" ]; } ||
       { [ -z "${FUZZ_RUNS:-}" ] && [ $(( SECONDS - start )) -ge "$seconds" ]; }; then
      # A failure's whole report (the stacks above libFuzzer's last lines) is kept beside the artifacts.
      [ "$status" -ne 0 ] && printf '%s\n' "$out" > "build-fuzz/fuzz_$1-failure.log" &&
        echo "(whole output: build-fuzz/fuzz_$1-failure.log)"
      # The input itself, in base64 when small, so that a CI log alone lets it be replayed
      # (base64 -d > unit; build-fuzz/fuzz_TARGET unit).
      local unit
      unit=$(sed -n 's/.*Test unit written to \(.*\)$/\1/p' <<< "$out" | tail -1)
      if [ "$status" -ne 0 ] && [ -f "$unit" ] && [ "$(stat -c %s "$unit")" -le 16384 ]; then
        echo "(the input, base64: $(base64 -w0 "$unit"))"
      fi
      # The start of the report (the stack), which the last lines below leave out.
      [ "$status" -ne 0 ] && grep -m1 -A30 -E '==[0-9]+== ?ERROR|DEADLYSIGNAL|runtime error:' <<< "$out" |
        head -31 || true
      tail -12 <<< "$out"
      break
    fi
  done
  [ -n "${batch:-}" ] && echo "fuzz_$1: $total inputs in $(( SECONDS - start )) s (processes of $batch)$( ((contained)) && echo "; $contained contained")"
  return "$status"
}
seed() { { printf "\\$(printf %03o "$1")"; cat; } > "$seeds/$2"; }  # a selector byte, then the file
shared=../shared/data

fuzz_scene() {
  # Its findings too (tests/data/fuzz/scene/): each run replays them under the per-input timeout.
  cp examples/*.isf tests/data/openscad/*.csg tests/data/fuzz/scene/* "$seeds"/ 2>/dev/null || true
  # The .scad -> .csg path: OpenSCAD's exports of its own regression models (those the corpus test made).
  for f in build/openscad-corpus/*.csg build/openscad-corpus-fast/*.csg; do [ -f "$f" ] && cp "$f" "$seeds"/; done
  awk -v dir="$seeds" '/^```scad/ { n++; f = sprintf("%s/doc%02d.isf", dir, n); inside = 1; next }
      /^```/ { inside = 0; next } inside { print >> f }' docs/scene-language.md
  # Absolute paths: fuzz_scene works in an empty directory of its own (tests/fuzz_scene.cpp).
  # Entropic scheduling scaled by execution time: the corpus is full of hull() and minkowski() scenes of a
  # second each under ASan beside parse errors of a millisecond, and mutating the slow ones kept the target at
  # 22-35 inputs a second.
  flags="-entropic_scale_per_exec_time=1" run scene 4096 "$( ((chosen)) && echo "$third" || echo "$seconds")"
}

fuzz_triangulate() { run triangulate 2048; }

# Mesh readers: a byte for the format (0 PLY, 1 OBJ, 2 STL, 3 OFF), then the file: the first 3 KB of real
# files, and whole small ones; and its findings (tests/data/fuzz/mesh/), replayed by every run.
fuzz_mesh_readers() {
  cp tests/data/fuzz/mesh/* "$seeds"/
  head -c 3000 data/cow.obj | seed 1 cow.obj
  [ -f $shared/meshes/bunny/bunny.ply ] && head -c 3000 $shared/meshes/bunny/bunny.ply | seed 0 bunny.ply
  [ -f $shared/meshes/vase/Vase.stl ] && head -c 3000 $shared/meshes/vase/Vase.stl | seed 2 vase.stl
  printf 'ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n' | seed 0 tet.ply
  printf 'OFF\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n' | seed 3 tet.off
  printf 'solid t\nfacet normal 0 0 -1\nouter loop\nvertex 0 0 0\nvertex 0 1 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid t\n' | seed 2 tri.stl
  run mesh_readers 4096
}

# Volume readers: a byte for the format (0 .nii, 1 .nii.gz, 2 .nrrd, 3 .mha), then the file.
fuzz_volume_readers() {
  /usr/bin/python3 - "$seeds/tiny.nii" <<'PY'
import struct, sys
h = bytearray(348)
struct.pack_into('<i', h, 0, 348)                          # sizeof_hdr
struct.pack_into('<8h', h, 40, 3, 2, 3, 4, 1, 1, 1, 1)     # dim
struct.pack_into('<hh', h, 70, 2, 8)                       # datatype uint8, bitpix
struct.pack_into('<8f', h, 76, 1, 0.5, 0.5, 2, 1, 1, 1, 1)  # pixdim
struct.pack_into('<f', h, 108, 352)                        # vox_offset
struct.pack_into('<h', h, 252, 1)                          # qform_code
h[344:348] = b'n+1\0'
open(sys.argv[1], 'wb').write(bytes(h) + b'\0\0\0\0' + bytes(range(24)))
PY
  seed 0 tiny-nii.nii < "$seeds/tiny.nii"
  gzip -c "$seeds/tiny.nii" | seed 1 tiny-nii.gz
  rm "$seeds/tiny.nii"
  atlas=../shared/data/volumes/colin27-mri-atlases/aal.nii.gz
  [ -f $atlas ] && head -c 3000 $atlas | seed 1 aal.nii.gz
  flair=../shared/data/volumes/flair-oblique-nrrd/FLAIR.nrrd
  [ -f $flair ] && head -c 3000 $flair | seed 2 flair.nrrd
  printf 'NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 3 2\nspacings: 1 1 2\nencoding: raw\n\n0123456789ab' | seed 2 tiny.nrrd
  # A detached header with a data file template, which teem hands to sprintf (checked before it does).
  printf 'NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 3 2\nencoding: raw\ndata file: s.%%02d.raw 1 2 1\n' | seed 2 template.nrrd
  printf 'ObjectType = Image\nNDims = 3\nDimSize = 2 3 2\nElementSpacing = 1 1 2\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n0123456789ab' | seed 3 tiny.mha
  run volume_readers 8192
}

# Raw voxels: 16 bytes of options (dims, type, flags, offset; tests/fuzz_raw.cpp), then the file.
fuzz_raw() {
  /usr/bin/python3 scripts/fuzz_seeds.py raw "$seeds"
  [ -f $shared/volumes/head-mr-small/HeadMRVolume.raw ] &&
    { printf '\x30\0\0\0\x3e\0\0\0\x02\0\0\0\0\0\0\0'; head -c 5952 $shared/volumes/head-mr-small/HeadMRVolume.raw; } > "$seeds/head-mr.raw"
  run raw 8192
}

# DICOM: two tiny CT slices of one series, and the header of a real slice (its pixels cut).
# GDCM asserts on many broken files (Debian builds it with assertions); isoforge runs it in a helper program
# that turns an abort into an IoError. This target runs GDCM in-process, and an assertion called from libgdcm
# jumps back to it and is counted (tests/fuzz_dicom.cpp); what GDCM held then is left, so the target runs in
# fresh processes of 5,000 inputs, with leak detection off, at exit too (what an assertion skipped over is
# anyone's; in isoforge the helper reads one series and ends). Any crash, other assertion, timeout or
# out-of-memory fails the run.
fuzz_dicom() {
  /usr/bin/python3 scripts/fuzz_seeds.py dicom "$seeds"
  local slice=$shared/volumes/ct-abdomen-dicom/series/1-057.dcm
  [ -f $slice ] && { printf '\xff\xff'; head -c 6000 $slice; } > "$seeds/abdomen-header"
  ASAN_OPTIONS=detect_leaks=0:intercept_tls_get_addr=0 batch=5000 flags="-detect_leaks=0" run dicom 8192
}

# .vdb: small whole files of each kind isoforge writes or reads (tests/data/fuzz/seeds), the start of a real one.
fuzz_vdb() {
  cp tests/data/fuzz/seeds/*.vdb "$seeds"/
  head -c 6000 data/sphere.vdb > "$seeds/sphere-start.vdb"
  # A claimed 64 GB buffer must be the bad_alloc the release build turns into an IoError (tests/fuzz_vdb.cpp):
  # single allocations up to 1 TB reach the allocator; what is resident stays under -rss_limit_mb.
  # Inputs up to 16 KB (the level set seed is cut there): an 80 KB one ran at a tenth of the speed, most of
  # it in OpenVDB allocating and clearing the 32^3 nodes its root names.
  # OpenVDB leaks the node it was reading when a corrupt file stops it (suppressed in tests/lsan.supp), and the
  # leak check libFuzzer runs after each such input took 90% of the time: leak detection is off here, with a
  # fresh process every 10,000 inputs. (The tests read the fuzz findings with leak detection on.)
  batch=10000 flags="-malloc_limit_mb=1048576 -detect_leaks=0" run vdb 16384
}

fuzz_bpt() {
  cp data/teapot.bpt "$seeds"/
  run bpt 32768
}

# Colour tables: a byte for the kind (0 binary .lut, 1 text), then the table.
fuzz_label_table() {
  /usr/bin/python3 scripts/fuzz_seeds.py label_table "$seeds"
  for f in $shared/volumes/colin27-mri-atlases/aal.nii.lut; do [ -f $f ] && seed 0 aal.lut < $f; done
  for f in $shared/volumes/colin27-mri-atlases/aal.nii.txt $shared/volumes/frog-tissue-labels/frog_tissue_labels.txt; do
    [ -f $f ] && seed 1 "$(basename $f)" < $f
  done
  run label_table 4096
}

# Expressions (byte 0) and .vm tapes (byte 1): the README's expressions and the start of the bundled model.
fuzz_expression() {
  grep -rhoE -- '--expr "[^"]+"' README.md docs/*.md | sed 's/^--expr "//; s/"$//' | sort -u | while read -r e; do
    printf '%s' "$e" | seed 0 "expr-$(printf '%s' "$e" | md5sum | cut -c1-8)"
  done
  head -c 3000 data/text.vm | seed 1 text.vm
  run expression 4096
}

for t in "${targets[@]}"; do
  seeds=build-fuzz/corpus-${t//_/-}
  mkdir -p "$seeds"
  "fuzz_$t"
done
