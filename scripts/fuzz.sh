#!/usr/bin/env bash
# Builds the fuzz targets with clang (libFuzzer + ASan + UBSan) into build-fuzz/ and runs each for a
# bounded time: the scene parser for SECONDS on a corpus seeded from the examples, the OpenSCAD exports
# (ours and, where installed, every 3D model of openscad-testing-data exported by openscad) and the docs;
# then, for a third of that time each, polyhedron-face triangulation, the mesh readers (PLY, OBJ, STL,
# OFF), the volume readers (NIfTI, NRRD, MetaImage; both seeded with the starts of real files and small
# whole ones) and the expression and .vm parsers.
# Usage: scripts/fuzz.sh [SECONDS]   (default 60). Exit status non-zero on any crash, leak or hang.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
source scripts/fuzz_tree.sh
configure_fuzz_tree
cmake --build build-fuzz --target fuzz_scene fuzz_triangulate fuzz_mesh_readers fuzz_volume_readers fuzz_expression
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
# Absolute paths: fuzz_scene works in an empty directory of its own (tests/fuzz_scene.cpp).
build-fuzz/fuzz_scene "$PWD/$corpus" -max_total_time="$seconds" -max_len=4096 -timeout=10 -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$PWD/build-fuzz/" 2>&1 | tail -25
third=$(( (seconds + 2) / 3 ))
run() {  # target corpus max_len
  build-fuzz/$1 "$PWD/$2" -max_total_time="$third" -max_len="$3" -timeout=10 -rss_limit_mb=2048 \
      -print_final_stats=1 -artifact_prefix="$PWD/build-fuzz/" 2>&1 | tail -12
}
mkdir -p build-fuzz/corpus-triangulate
run fuzz_triangulate build-fuzz/corpus-triangulate 2048

# Mesh readers: a byte for the format (0 PLY, 1 OBJ, 2 STL, 3 OFF), then the file: the first 3 KB of real
# files, and whole small ones.
seeds=build-fuzz/corpus-mesh
mkdir -p "$seeds"
seed() { { printf "\\$(printf %03o "$1")"; cat; } > "$seeds/$2"; }
head -c 3000 data/cow.obj | seed 1 cow.obj
shared=../shared/data/meshes
[ -f $shared/bunny/bunny.ply ] && head -c 3000 $shared/bunny/bunny.ply | seed 0 bunny.ply
[ -f $shared/vase/Vase.stl ] && head -c 3000 $shared/vase/Vase.stl | seed 2 vase.stl
printf 'ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n' | seed 0 tet.ply
printf 'OFF\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n' | seed 3 tet.off
printf 'solid t\nfacet normal 0 0 -1\nouter loop\nvertex 0 0 0\nvertex 0 1 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid t\n' | seed 2 tri.stl
run fuzz_mesh_readers "$seeds" 4096

# Volume readers: a byte for the format (0 .nii, 1 .nii.gz, 2 .nrrd, 3 .mha), then the file.
seeds=build-fuzz/corpus-volume
mkdir -p "$seeds"
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
printf 'ObjectType = Image\nNDims = 3\nDimSize = 2 3 2\nElementSpacing = 1 1 2\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n0123456789ab' | seed 3 tiny.mha
run fuzz_volume_readers "$seeds" 8192

# Expressions (byte 0) and .vm tapes (byte 1): the README's expressions and the start of the bundled model.
seeds=build-fuzz/corpus-expression
mkdir -p "$seeds"
grep -rhoE -- '--expr "[^"]+"' README.md docs/*.md | sed 's/^--expr "//; s/"$//' | sort -u | while read -r e; do
  printf '%s' "$e" | seed 0 "expr-$(printf '%s' "$e" | md5sum | cut -c1-8)"
done
head -c 3000 data/text.vm | seed 1 text.vm
run fuzz_expression "$seeds" 4096
