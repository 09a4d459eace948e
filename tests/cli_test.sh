#!/usr/bin/env bash
# End-to-end checks of the isoforge command line: exit codes, messages, outputs.
# Usage: cli_test.sh ISOFORGE SOURCE_DIR
set -u
bin=$1
src=$2
shared=$src/../shared/data
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
expect_exit() {  # expected-code description command...
    local want=$1 what=$2
    shift 2
    "$@" >"$tmp/out" 2>"$tmp/err"
    local got=$?
    if [ "$got" -eq "$want" ]; then ok; else bad "$what: exit $got, expected $want"; cat "$tmp/err"; fi
}

expect_exit 0 "--help" "$bin" --help
grep -q "mesh" "$tmp/out" && ok || bad "--help lists the mesh command"
expect_exit 0 "--version" "$bin" --version
grep -q "OpenVDB 10" "$tmp/out" && ok || bad "--version names OpenVDB"
# The launcher (app/launcher.c) starts the program with malloc's heap in huge pages, adds the tunable to the
# user's others, leaves the user's own choice alone, and says so when the program is missing.
grep -q "malloc: GLIBC_TUNABLES=glibc.malloc.hugetlb=1$" "$tmp/out" && ok || bad "the launcher asks for huge pages"
GLIBC_TUNABLES=glibc.malloc.tcache_count=5 expect_exit 0 "--version, other tunables" "$bin" --version
grep -q "GLIBC_TUNABLES=glibc.malloc.tcache_count=5:glibc.malloc.hugetlb=1$" "$tmp/out" && ok ||
    bad "the launcher adds the tunable to the user's"
GLIBC_TUNABLES=glibc.malloc.hugetlb=0 expect_exit 0 "--version, hugetlb=0" "$bin" --version
grep -q "GLIBC_TUNABLES=glibc.malloc.hugetlb=0$" "$tmp/out" && ok || bad "the user's hugetlb=0 wins"
# A launcher copied away from the build tree still finds its program there (checked only for a build tree's
# launcher, with no installed program it could find instead).
if [ -e "$(dirname "$bin")/../lib/isoforge/isoforge-main" ] && [ ! -e /usr/local/lib/isoforge/isoforge-main ]; then
    mkdir -p "$tmp/moved/bin" && cp "$(readlink -f "$bin")" "$tmp/moved/bin/isoforge"
    expect_exit 0 "a launcher moved away finds the build tree's program" "$tmp/moved/bin/isoforge" --help
fi
expect_exit 0 "mesh --help" "$bin" mesh --help
grep -q -- "--iso" "$tmp/out" && ok || bad "mesh --help lists --iso"
expect_exit 2 "no subcommand" "$bin"
expect_exit 2 "unknown subcommand" "$bin" frobnicate
expect_exit 2 "unknown option" "$bin" mesh "$src/data/sphere.vdb" -o "$tmp/a.ply" --bogus
expect_exit 2 "missing -o" "$bin" mesh "$src/data/sphere.vdb"
expect_exit 2 "bad --threads" "$bin" --threads 0 info "$src/data/sphere.vdb"

# The main job on bundled data.
expect_exit 0 "info" "$bin" info "$src/data/sphere.vdb"
grep -q "270638" "$tmp/out" && ok || bad "info reports the active voxel count"
expect_exit 0 "mesh" "$bin" mesh "$src/data/sphere.vdb" -o "$tmp/sphere.ply"
grep -q "triangles" "$tmp/out" && ok || bad "mesh prints a summary"
expect_exit 0 "mesh --quiet" "$bin" --quiet mesh "$src/data/sphere.vdb" -o "$tmp/q.obj"
[ ! -s "$tmp/out" ] && ok || bad "--quiet prints nothing"
expect_exit 0 "global option after the command" "$bin" mesh "$src/data/sphere.vdb" -o "$tmp/t.stl" --threads 1 --quiet
expect_exit 0 "check --strict" "$bin" check --strict "$tmp/sphere.ply" "$tmp/q.obj" "$tmp/t.stl"
grep -q "genus           0" "$tmp/out" && ok || bad "check reports genus 0"
cmp -s "$tmp/sphere.ply" <("$bin" --threads 1 --quiet mesh "$src/data/sphere.vdb" -o "$tmp/one.ply"; cat "$tmp/one.ply") \
    && ok || bad "1 thread and all threads give the same file"
if [ -f "$shared/volumes/openvdb-samples/smoke.vdb" ]; then
    expect_exit 0 "fog mesh" "$bin" mesh "$shared/volumes/openvdb-samples/smoke.vdb" --grid density --iso 0.2 -o "$tmp/smoke.obj" --stats
    grep -q "watertight      yes" "$tmp/out" && ok || bad "smoke mesh is watertight"
    expect_exit 1 "check --strict on an open mesh" "$bin" check --strict "$shared/meshes/bunny/bunny.ply"
    expect_exit 0 "check on an open mesh" "$bin" check "$shared/meshes/bunny/bunny.ply"
    grep -q "boundary edges" "$tmp/out" && ok || bad "check reports the bunny's holes"
fi

# Bad input: exit 1, a one-line message naming the file, no output file.
expect_exit 1 "missing input" "$bin" mesh "$tmp/nope.vdb" -o "$tmp/x.ply"
grep -q "nope.vdb" "$tmp/err" && ok || bad "message names the missing file"
[ "$(wc -l <"$tmp/err")" -eq 1 ] && ok || bad "one-line message"
# An unbounded field from a file is the file's doing (1, as a fuzzed scene turned into a plane made it);
# from --expr, the command line's (2).
printf 'plane(n = [0, 0, 1], d = 0);\n' > "$tmp/plane.isf"
expect_exit 1 "unbounded scene file" "$bin" mesh "$tmp/plane.isf" -o "$tmp/x.ply"
expect_exit 2 "unbounded --expr" "$bin" mesh --expr "z" -o "$tmp/x.ply"
echo "not a vdb" >"$tmp/text.vdb"
expect_exit 1 "non-VDB input" "$bin" mesh "$tmp/text.vdb" -o "$tmp/x.ply"
# fuzz_vdb's finding: a voxel buffer claiming 64 GB is OpenVDB's bad_alloc, an IoError (tested here, in the
# release build: under AddressSanitizer operator new cannot throw; tests/fuzz_vdb.cpp).
expect_exit 1 "VDB claiming a 64 GB buffer" "$bin" info "$src/tests/data/fuzz/cli/vdb-blosc-chunk-of-64-gb.vdb"
grep -q "vdb-blosc-chunk-of-64-gb.vdb: corrupt.*more than compression could make" "$tmp/err" && ok || bad "the 64 GB claim names the file"
head -c 5000 "$src/data/sphere.vdb" >"$tmp/cut.vdb"
expect_exit 1 "truncated VDB" "$bin" mesh "$tmp/cut.vdb" -o "$tmp/x.ply"
expect_exit 1 "truncated VDB info" "$bin" info "$tmp/cut.vdb"
expect_exit 1 "unknown grid" "$bin" mesh "$src/data/sphere.vdb" --grid nothing -o "$tmp/x.ply"
[ ! -e "$tmp/x.ply" ] && ok || bad "no output file after errors"
expect_exit 2 "bad output extension" "$bin" mesh "$src/data/sphere.vdb" -o "$tmp/x.xyz"
printf 'v 0 0 0\nf 1 2 3\n' >"$tmp/bad.obj"
expect_exit 1 "bad OBJ" "$bin" check "$tmp/bad.obj"
grep -q "bad.obj:2:" "$tmp/err" && ok || bad "OBJ error has line and column"
expect_exit 1 "unwritable output" "$bin" mesh "$src/data/sphere.vdb" -o "$tmp/no/such/dir/x.ply"

# Implicit fields: shapes, expressions, .vm models, sampling, slices.
expect_exit 0 "mesh --shape" "$bin" mesh --shape "torus(R=1, r=0.3)" --voxel 0.02 -o "$tmp/torus.ply"
expect_exit 0 "torus check" "$bin" check --strict "$tmp/torus.ply"
grep -q "genus           1" "$tmp/out" && ok || bad "the torus has genus 1"
expect_exit 0 "mesh --expr" "$bin" mesh --expr "x^4 - 5*x^2 + y^4 - 5*y^2 + z^4 - 5*z^2 + 11.8" --box -3,-3,-3,3,3,3 \
    --resolution 96 -o "$tmp/goursat.ply"
expect_exit 0 "goursat check" "$bin" check --strict "$tmp/goursat.ply"
expect_exit 0 "sample .vm" "$bin" sample "$src/data/text.vm" --resolution 64 -o "$tmp/text.vdb"
expect_exit 0 "info of the sampled grid" "$bin" info "$tmp/text.vdb"
expect_exit 0 "mesh .vm" "$bin" mesh "$src/data/text.vm" --resolution 64 -o "$tmp/text.ply"
expect_exit 0 "slice --sign" "$bin" slice "$src/data/text.vm" --plane z=0 --range -1,1 --size 256 --sign -o "$tmp/slice.png"
[ -s "$tmp/slice.png" ] && ok || bad "slice wrote a PNG"
expect_exit 0 "slice values" "$bin" slice "$src/data/text.vm" --plane z=0.2 --range -2,2 --size 128 -o "$tmp/dist.png"
expect_exit 0 "shapes" "$bin" shapes
grep -q "torus" "$tmp/out" && ok || bad "shapes lists the torus"
expect_exit 1 "bad expression" "$bin" mesh --expr "x^2 + " --box -1,-1,-1,1,1,1 -o "$tmp/e.ply"
grep -q "expression:1:" "$tmp/err" && ok || bad "expression error has a column"
expect_exit 1 "unknown shape" "$bin" mesh --shape "blob(1)" -o "$tmp/e.ply"
expect_exit 2 "unbounded without --box" "$bin" mesh --expr "x + y" -o "$tmp/e.ply"
printf '_0 var-x\n_1 frob _0\n' >"$tmp/bad.vm"
expect_exit 1 "bad .vm" "$bin" slice "$tmp/bad.vm" -o "$tmp/e.png"
grep -q "bad.vm:2:4: unknown op 'frob'" "$tmp/err" && ok || bad ".vm error has line and column"
expect_exit 1 "absurd resolution" "$bin" mesh --shape "sphere(r=1)" --resolution 1000000 -o "$tmp/e.ply"
grep -q "would need about" "$tmp/err" && ok || bad "absurd request names the memory it would need"
[ ! -e "$tmp/e.ply" ] && [ ! -e "$tmp/e.png" ] && ok || bad "no output after field errors"

# render: the issue's command lines, on the bundled scene, grid and a mesh.
expect_exit 0 "render showcase (Embree)" "$bin" render "$src/examples/showcase.isf" --size 160x120 --resolution 128 -o "$tmp/showcase.png"
grep -q "Embree" "$tmp/out" && grep -q "Mrays/s" "$tmp/out" && ok || bad "render prints a summary"
expect_exit 0 "render showcase (march)" "$bin" render "$src/examples/showcase.isf" --method march --size 96x72 -o "$tmp/showcase_m.png"
# A scene whose camera looks from its target is the file's fault (1); the same from --eye, the command line's (2).
printf 'camera(eye = [1, 1, 1], target = [1, 1, 1]);\nsphere(r = 1);\n' >"$tmp/eye.isf"
expect_exit 1 "scene camera eye at target" "$bin" render "$tmp/eye.isf" --size 32x24 -o "$tmp/eye.png"
expect_exit 2 "--eye at the target" "$bin" render --shape "sphere(r=1)" --eye 0,0,0 --target 0,0,0 --size 32x24 -o "$tmp/eye.png"
expect_exit 0 "render a grid to EXR" "$bin" render "$src/data/sphere.vdb" --iso 0 --size 192x108 --spp 4 -o "$tmp/s.exr"
expect_exit 0 "render a mesh" "$bin" render "$tmp/sphere.ply" --camera-auto -o "$tmp/mesh.png" --size 64x64
expect_exit 0 "render AOVs" "$bin" render "$src/examples/bracket.isf" --aov depth,normal,id --size 64x48 -o "$tmp/frame.exr"
chans=$(oiiotool --info -v "$tmp/frame.exr" 2>/dev/null | grep "channel list")
for c in R G B A Z N.x N.y N.z id; do grep -qw -- "$c" <<<"$chans" || { bad "EXR lacks channel $c ($chans)"; break; }; done && ok
expect_exit 0 "render translucent iso layers" "$bin" render "$src/data/sphere.vdb" --iso 0:skin:0.35 --iso -0.1:ivory --size 64x64 -o "$tmp/layers.png"
expect_exit 2 "AOVs need EXR" "$bin" render "$src/data/sphere.vdb" --aov depth -o "$tmp/r.png"
expect_exit 2 "bad --size" "$bin" render "$src/data/sphere.vdb" --size 10by10 -o "$tmp/r.png"
expect_exit 1 "absurd --size" "$bin" render "$src/data/sphere.vdb" --size 100000x100000 -o "$tmp/r.png"
expect_exit 2 "bad --iso colour" "$bin" render "$src/data/sphere.vdb" --iso 0:nocolour -o "$tmp/r.png"
[ ! -e "$tmp/r.png" ] && ok || bad "no image after render errors"
expect_exit 0 "render --quiet prints nothing" "$bin" --quiet render --shape "torus(R=1, r=0.3)" --size 32x32 -o "$tmp/q.png"
[ ! -s "$tmp/out" ] && ok || bad "--quiet render is silent"

# primitive (issue #7's first command line)
expect_exit 0 "primitive cone" "$bin" primitive cone --resolution 64 -o "$tmp/cone.ply"
expect_exit 0 "primitive cone is closed" "$bin" check --strict "$tmp/cone.ply"
for p in cube cylinder sphere icosphere torus; do
    "$bin" --quiet primitive $p --resolution 4 -o "$tmp/p_$p.obj" && "$bin" check --strict "$tmp/p_$p.obj" >/dev/null && ok || bad "primitive $p closed"
done
expect_exit 2 "unknown primitive" "$bin" primitive teapot -o "$tmp/t.ply"
expect_exit 1 "bad primitive resolution" "$bin" primitive cone --resolution 2 -o "$tmp/t.ply"
[ ! -e "$tmp/t.ply" ] && ok || bad "no output after primitive errors"

# strips
expect_exit 0 "strips" "$bin" strips "$tmp/cone.ply" -o "$tmp/cone.strips"
grep -q "expanded back: the same triangles" "$tmp/out" && ok || bad "strips expand back"
grep -q "^s " "$tmp/cone.strips" && ok || bad "strips file has strips"
expect_exit 1 "strips of a missing file" "$bin" strips "$tmp/none.ply"

# check --repair: a mesh with every other triangle flipped comes back valid
awk '/^f /{n++; if (n%2==0) {s="f"; for (i=NF; i>=2; i--) s=s" "$i; print s; next}} {print}' "$shared/meshes/cow/cow.obj" >"$tmp/flipped.obj" 2>/dev/null
if [ -s "$tmp/flipped.obj" ]; then
    expect_exit 0 "check --repair" "$bin" check "$tmp/flipped.obj" --repair -o "$tmp/fixed.ply"
    grep -q "triangles flipped" "$tmp/out" && ok || bad "repair reports what it did"
    "$bin" check "$tmp/flipped.obj" | grep -q "oriented        NO" && ok || bad "the flipped cow is misoriented"
    "$bin" check "$tmp/fixed.ply" >"$tmp/fixed.txt"
    grep -q "oriented        yes" "$tmp/fixed.txt" && grep -q "watertight      yes" "$tmp/fixed.txt" &&
        grep -q "outward         yes" "$tmp/fixed.txt" && ok || bad "repaired cow is closed, oriented, outward"
fi
expect_exit 2 "--repair needs -o" "$bin" check "$tmp/cone.ply" --repair

# voxelize: mesh -> level set -> mesh
expect_exit 0 "voxelize a closed mesh" "$bin" voxelize "$tmp/cone.ply" --resolution 64 -o "$tmp/cone.vdb"
grep -q "signed level set" "$tmp/out" && ok || bad "voxelize says signed"
expect_exit 0 "mesh the voxelized cone" "$bin" mesh "$tmp/cone.vdb" -o "$tmp/cone_back.ply"
expect_exit 0 "voxelized cone meshes closed" "$bin" check --strict "$tmp/cone_back.ply"
if [ -f "$shared/meshes/bunny/bunny.ply" ]; then
    expect_exit 0 "voxelize an open mesh" "$bin" voxelize "$shared/meshes/bunny/bunny.ply" --resolution 64 -o "$tmp/bunny.vdb"
    grep -q "not closed" "$tmp/err" && ok || bad "open mesh gives a warning"
fi
expect_exit 1 "absurd voxel" "$bin" voxelize "$tmp/cone.ply" --voxel 0.0000001 -o "$tmp/v.vdb"
grep -q "would need about" "$tmp/err" && ok || bad "voxelize refuses with an estimate"
[ ! -e "$tmp/v.vdb" ] && ok || bad "no output after a refused voxelize"

# subdivide
expect_exit 0 "subdivide loop" "$bin" subdivide "$tmp/p_cube.obj" --scheme loop --levels 2 -o "$tmp/cube_loop.ply"
expect_exit 0 "loop keeps a closed manifold" "$bin" check --strict "$tmp/cube_loop.ply"
expect_exit 0 "subdivide butterfly" "$bin" subdivide "$tmp/p_cube.obj" --scheme butterfly --levels 3 -o "$tmp/rounded.ply"
expect_exit 0 "butterfly keeps a closed manifold" "$bin" check --strict "$tmp/rounded.ply"
expect_exit 2 "unknown scheme" "$bin" subdivide "$tmp/p_cube.obj" --scheme catmull -o "$tmp/b.ply"
expect_exit 1 "absurd levels" "$bin" subdivide "$shared/meshes/bunny/bunny.ply" --levels 8 -o "$tmp/b.ply"
grep -q "would need about" "$tmp/err" && ok || bad "subdivide refuses with an estimate"
expect_exit 0 "subdivide loop with creases" "$bin" subdivide "$tmp/p_cube.obj" --levels 2 --crease-angle 30 -o "$tmp/crease.glb"
grep -q -- "-> [0-9,]* triangles" "$tmp/out" && ok || bad "creased subdivide summary"
expect_exit 2 "creases are Loop's" "$bin" subdivide "$tmp/p_cube.obj" --scheme butterfly --crease-angle 30 -o "$tmp/b.ply"

# tessellate: Newell's teapot
expect_exit 0 "tessellate the teapot" "$bin" tessellate "$src/data/teapot.bpt" --resolution 16 -o "$tmp/teapot.ply"
grep -q "32 patches at resolution 16: .* 256 boundary edges" "$tmp/out" && ok || bad "tessellate summary"
expect_exit 0 "check the teapot" "$bin" check "$tmp/teapot.ply"
grep -q "oriented        yes" "$tmp/out" && ok || bad "teapot consistently oriented"
expect_exit 0 "teapot as glTF" "$bin" tessellate "$src/data/teapot.bpt" --resolution 8 -o "$tmp/teapot.glb"
[ "$(head -c 4 "$tmp/teapot.glb")" = "glTF" ] && ok || bad "teapot.glb starts with the glTF magic"
head -c 3000 "$src/data/teapot.bpt" >"$tmp/cut.bpt"
expect_exit 1 "truncated patch file" "$bin" tessellate "$tmp/cut.bpt" -o "$tmp/cut.ply"
grep -q "cut.bpt:[0-9]*:[0-9]*: unexpected end of file" "$tmp/err" && ok || bad "truncated .bpt error names the position"
[ ! -e "$tmp/cut.ply" ] && ok || bad "no output from a truncated patch file"
expect_exit 1 "absurd tessellation" "$bin" tessellate "$src/data/teapot.bpt" --resolution 4000 -o "$tmp/t.ply"
grep -q "MiB" "$tmp/err" && ok || bad "tessellate refuses with an estimate"

# glTF output from the mesher, with vertex colours
expect_exit 0 "mesh to .glb" "$bin" mesh "$src/data/sphere.vdb" -o "$tmp/sphere.glb"
[ "$(head -c 4 "$tmp/sphere.glb")" = "glTF" ] && ok || bad "sphere.glb starts with the glTF magic"
expect_exit 1 ".glb is not an input" "$bin" check "$tmp/sphere.glb"
grep -q "output format" "$tmp/err" && ok || bad ".glb input refused clearly"

# Medical volumes (the command lines of issue #6, on the shared data)
vols=$shared/volumes
if [ -d "$vols" ]; then
    ct=$vols/ct-abdomen-dicom/series
    expect_exit 0 "info of a DICOM series" "$bin" info "$ct"
    grep -q "512 x 512 x 48" "$tmp/out" && grep -q "1.07422 x 1.07422 x 3 mm" "$tmp/out" && grep -q "HU" "$tmp/out" \
        && ok || bad "DICOM info: dims, spacing, HU"
    expect_exit 0 "bone from a DICOM directory" "$bin" mesh "$ct" --iso 300 --smooth 1 -o "$tmp/bone.ply"
    expect_exit 0 "bone is closed" "$bin" check --strict "$tmp/bone.ply"
    expect_exit 0 "atlas labels" "$bin" mesh "$vols/colin27-mri-atlases/aal.nii.gz" --labels --colors "$vols/colin27-mri-atlases/aal.nii.lut" -o "$tmp/atlas.ply"
    grep -q "meshed 116 labels.*every label closed" "$tmp/out" && ok || bad "116 AAL labels, all closed"
    grep -q "property uchar red" "$tmp/atlas.ply" && ok || bad "atlas.ply has vertex colours"
    expect_exit 0 "frog labels, one file each" "$bin" mesh "$vols/frog-tissue-labels/frogtissue.mhd" --labels --colors "$vols/frog-tissue-labels/frog_tissue_labels.txt" --split -o "$tmp/frog.glb"
    [ -s "$tmp/frog_13_skeleton.glb" ] && ok || bad "frog skeleton file"
    expect_exit 0 "bone under translucent skin" "$bin" render "$vols/headsq-ct-nrrd/quarter.nhdr" --iso 1150:ivory --iso 500:skin:0.35 -o "$tmp/head.png" --size 320x240
    expect_exit 0 "bundled head, camera turned" "$bin" render "$src/data/headsq/quarter.nhdr" --iso 1150:ivory --up 0,0,-1 -o "$tmp/head_up.png" --size 160x120
    expect_exit 2 "zero up direction" "$bin" render "$src/data/headsq/quarter.nhdr" --up 0,0,0 -o "$tmp/head_up0.png"
    expect_exit 0 "negative iso-value" "$bin" render "$ct" --iso 300:ivory --iso -300:skin:0.35 -o "$tmp/ct.png" --size 160x120
    expect_exit 0 "MIP" "$bin" render "$vols/colin27-mri-atlases/ch2.nii.gz" --mip axial -o "$tmp/mip.png"
    grep -q "181x217" "$tmp/out" && ok || bad "axial MIP of 181 x 217"
    expect_exit 0 "volume rendering" "$bin" render "$ct" --volume --preset ct-bone -o "$tmp/vr.png" --size 160x120
    expect_exit 0 "voxels" "$bin" render "$vols/frog-tissue-labels/frogtissue.mhd" --voxels -o "$tmp/voxels.png" --size 160x120
    expect_exit 0 "CT slice with window/level" "$bin" slice "$ct" --axis axial --index 24 --window 400 --level 40 -o "$tmp/slice.png"
    expect_exit 2 "slice out of range" "$bin" slice "$ct" --axis axial --index 48 -o "$tmp/bad_slice.png"
    grep -q "0..47" "$tmp/err" && ok || bad "slice range in the error"
    [ ! -e "$tmp/bad_slice.png" ] && ok || bad "no image from a bad slice"
    expect_exit 0 "convert to vdb" "$bin" convert "$vols/headsq-ct-nrrd/quarter.nhdr" -o "$tmp/head.vdb"
    expect_exit 0 "mesh the converted vdb" "$bin" mesh "$tmp/head.vdb" --iso 1150 -o "$tmp/head_bone.ply"
    expect_exit 0 "convert to NIfTI" "$bin" convert "$vols/flair-oblique-nrrd/FLAIR.nrrd" -o "$tmp/flair.nii.gz"
    expect_exit 0 "info of the NIfTI" "$bin" info "$tmp/flair.nii.gz"
    grep -q "origin       (64.898, 110.431, -27.926)" "$tmp/out" && ok || bad "FLAIR origin kept through NIfTI"
    head -c 500000 "$vols/colin27-mri-atlases/ch2.nii.gz" >"$tmp/cut.nii.gz"
    expect_exit 1 "truncated NIfTI" "$bin" mesh "$tmp/cut.nii.gz" --iso 50 -o "$tmp/cut.ply"
    grep -q "truncated" "$tmp/err" && ok || bad "truncated NIfTI says so"
    [ ! -e "$tmp/cut.ply" ] && ok || bad "no mesh from a truncated volume"
    head -c 100 /dev/zero >"$tmp/x.raw"
    expect_exit 1 "raw without dims" "$bin" info "$tmp/x.raw"
    grep -q -- "--dims" "$tmp/err" && ok || bad "raw voxels ask for --dims"
    expect_exit 1 "raw larger than the file" "$bin" info "$tmp/x.raw" --dims 10,10,10 --type uint8
    grep -q "need 1000 bytes; the file has 100" "$tmp/err" && ok || bad "raw size error"
fi

# OpenSCAD models (.scad) through openscad; its messages on their lines; degenerate objects warned about.
if command -v openscad >/dev/null; then
    scad=$src/tests/data/openscad/example001.scad
    expect_exit 0 "mesh .scad" "$bin" mesh "$scad" -o "$tmp/e1.stl" --resolution 64 -D '$fn=24'
    expect_exit 0 "check the .scad mesh" "$bin" check --strict "$tmp/e1.stl"
    grep -q "genus           5" "$tmp/out" && ok || bad "example001: a sphere through three cylinders has genus 5"
    expect_exit 0 "check-scene .scad" "$bin" check-scene "$scad" --define '$fn=8'
    grep -q "sphere (\$fn=8)" "$tmp/out" && ok || bad "check-scene shows the -D value reaching the tree"
    grep -q "example001.scad: openscad: ECHO: version" "$tmp/out" && ok || bad "OpenSCAD's echo is shown"
    expect_exit 0 "render .scad" "$bin" render "$scad" -o "$tmp/e1.png" --size 64x48 --resolution 48
    printf 'cube(1);\nsphere(;\n' >"$tmp/bad.scad"
    expect_exit 1 "a .scad syntax error" "$bin" mesh "$tmp/bad.scad" -o "$tmp/bad.stl"
    grep -q "bad.scad:2: openscad: ERROR: Parser error" "$tmp/err" && ok || bad "the syntax error names file:line"
    [ ! -e "$tmp/bad.stl" ] && ok || bad "no output after a .scad error"
    expect_exit 2 "a bad --define" "$bin" mesh "$scad" -D nodefinition -o "$tmp/x.stl"
    ISOFORGE_OPENSCAD=/nonexistent/openscad expect_exit 1 "openscad missing" "$bin" mesh "$scad" -o "$tmp/x.stl"
    grep -q "Debian package openscad" "$tmp/err" && ok || bad "the missing-openscad error names the package"
    printf 'cube(0);\nlinear_extrude(1) sphere(1);\ntranslate([3, 0, 0]) cube(1);\n' >"$tmp/degenerate.scad"
    expect_exit 0 "degenerate objects are ignored" "$bin" mesh "$tmp/degenerate.scad" -o "$tmp/d.stl" --resolution 32
    grep -q "degenerate.scad (as CSG):1:1: cube() with a zero" "$tmp/err" && ok || bad "cube(0) is warned about on its line"
    grep -q "ignoring the 3D object sphere()" "$tmp/err" && ok || bad "a 3D child of an extrusion is warned about"
    printf 'cube(0);\n' >"$tmp/empty.scad"
    expect_exit 1 "an empty model" "$bin" mesh "$tmp/empty.scad" -o "$tmp/e.stl"
    grep -q "the scene is empty" "$tmp/err" && ok || bad "an empty model says so"
else
    echo "cli_test: openscad is not installed; the .scad checks are skipped"
fi

# Feature vertices (--sharp): a box with a turned hole and the bundled sphere grid, checked for
# closedness, orientation and self-intersections; the self-intersection check finds overlapping cubes.
printf 'difference() { cube(10, center = true); rotate([30, 20, 10]) cube([4, 4, 20], center = true); }\n' >"$tmp/holed.csg"
expect_exit 0 "mesh --sharp (scene)" "$bin" mesh "$tmp/holed.csg" --sharp --resolution 48 -o "$tmp/holed.ply"
grep -q "feature vertices" "$tmp/out" && ok || bad "mesh --sharp: no summary of feature vertices"
expect_exit 0 "check --self-intersections --strict (sharp)" "$bin" check --strict --self-intersections "$tmp/holed.ply"
expect_exit 0 "mesh --sharp (grid)" "$bin" mesh "$src/data/sphere.vdb" --sharp -o "$tmp/sphere_sharp.ply"
expect_exit 0 "check --self-intersections --strict (sharp grid)" "$bin" check --strict --self-intersections "$tmp/sphere_sharp.ply"
# OpenSCAD models (.csg, .scad) get feature vertices by default, our scenes do not; --no-sharp turns them
# off; --sharp with --no-sharp is a usage error.
expect_exit 0 "mesh (.csg: sharp by default)" "$bin" mesh "$tmp/holed.csg" --resolution 48 -o "$tmp/holed_default.ply"
cmp -s "$tmp/holed.ply" "$tmp/holed_default.ply" && ok || bad "a .csg is not meshed as with --sharp by default"
expect_exit 0 "mesh --no-sharp (.csg)" "$bin" mesh "$tmp/holed.csg" --no-sharp --resolution 48 -o "$tmp/holed_plain.ply"
grep -q "feature vertices" "$tmp/out" && bad "--no-sharp: feature vertices still made" || ok
cmp -s "$tmp/holed.ply" "$tmp/holed_plain.ply" && bad "--no-sharp: the same mesh as --sharp" || ok
cp "$tmp/holed.csg" "$tmp/holed.isf"
expect_exit 0 "mesh (.isf: plain by default)" "$bin" mesh "$tmp/holed.isf" --resolution 48 -o "$tmp/holed_isf.ply"
cmp -s "$tmp/holed_plain.ply" "$tmp/holed_isf.ply" && ok || bad "an .isf scene is not meshed plain by default"
expect_exit 2 "mesh --sharp --no-sharp" "$bin" mesh "$tmp/holed.csg" --sharp --no-sharp -o "$tmp/x.ply"
# --normals with feature vertices: one normal per side of a crease (copies of the crease's vertices), closed
# by position, which check counts; --crease-angle 180 keeps one normal per vertex.
expect_exit 0 "mesh --sharp --normals" "$bin" mesh "$tmp/holed.csg" --normals --resolution 48 -o "$tmp/holed_n.ply"
grep -q "copies of vertices on creases" "$tmp/out" && ok || bad "--normals: no crease copies in the summary"
expect_exit 0 "check --strict (crease normals)" "$bin" check --strict --self-intersections "$tmp/holed_n.ply"
grep -q "copies sharing a position, counted as one" "$tmp/out" && ok || bad "check: crease copies not counted as one"
expect_exit 0 "mesh --crease-angle 180" "$bin" mesh "$tmp/holed.csg" --normals --crease-angle 180 --resolution 48 \
  -o "$tmp/holed_n180.ply"
grep -q "copies of vertices on creases" "$tmp/out" && bad "--crease-angle 180: vertices still split" || ok
expect_exit 2 "mesh --crease-angle 200" "$bin" mesh "$tmp/holed.csg" --normals --crease-angle 200 -o "$tmp/x.ply"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv .2 .2 -.5\nv .2 .2 .5\nv .9 .9 .2\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\nf 5 6 7\n' >"$tmp/pierced.obj"
expect_exit 0 "check --self-intersections (pierced)" "$bin" check --self-intersections "$tmp/pierced.obj"
grep -q "self-intersect  YES" "$tmp/out" && ok || bad "check --self-intersections: the piercing triangle not found"

# compare: a mesh against itself is 0 apart (to float precision); a missing file is exit 1.
expect_exit 0 "compare (itself)" "$bin" compare "$tmp/holed.ply" "$tmp/holed.ply" --voxel 1
awk '/^hausdorff/ { exit !($2 < 0.01) }' "$tmp/out" && ok || { bad "compare: a mesh is not 0 from itself"; cat "$tmp/out"; }
expect_exit 1 "compare (missing file)" "$bin" compare "$tmp/holed.ply" "$tmp/nope.stl"

# --memory: meshing in slabs writes the in-memory path's bytes (PLY binary and ASCII, OBJ, STL), under the
# limit (peak resident memory in the summary), with .scad/.csg plain; what needs the whole mesh is refused.
for f in ply obj stl; do
    "$bin" --quiet mesh --shape "torus(R=1, r=0.3)" --voxel 0.006 --normals -o "$tmp/whole.$f"
    expect_exit 0 "mesh --memory (.$f)" "$bin" mesh --shape "torus(R=1, r=0.3)" --voxel 0.006 --normals -o "$tmp/slabs.$f" --memory 300M
    cmp -s "$tmp/whole.$f" "$tmp/slabs.$f" && ok || bad "mesh --memory (.$f): not the in-memory path's bytes"
done
awk '/^peak memory/ { v = $3; gsub(",", "", v); exit !(v + 0 > 0 && v + 0 <= 300) }' "$tmp/out" && ok \
    || { bad "mesh --memory: peak memory not reported under the limit"; cat "$tmp/out"; }
"$bin" --quiet mesh "$tmp/holed.isf" --resolution 300 --ascii -o "$tmp/holed_whole.ply"
expect_exit 0 "mesh --memory (scene, ASCII)" "$bin" --quiet mesh "$tmp/holed.isf" --resolution 300 --ascii -o "$tmp/holed_slabs.ply" --memory 1G
cmp -s "$tmp/holed_whole.ply" "$tmp/holed_slabs.ply" && ok || bad "mesh --memory (scene): not the in-memory path's bytes"
expect_exit 0 "mesh --memory (.csg: plain)" "$bin" mesh "$tmp/holed.csg" --resolution 48 -o "$tmp/holed_csg_slabs.ply" --memory 1G
cmp -s "$tmp/holed_plain.ply" "$tmp/holed_csg_slabs.ply" && ok || bad "mesh --memory (.csg): not the plain mesh"
expect_exit 2 "mesh --memory --sharp" "$bin" mesh "$tmp/holed.csg" --sharp -o "$tmp/x.ply" --memory 1G
expect_exit 2 "mesh --memory --max-error" "$bin" mesh "$tmp/holed.csg" --max-error 0.1 -o "$tmp/x.ply" --memory 1G
expect_exit 2 "mesh --memory (.glb)" "$bin" mesh "$tmp/holed.csg" -o "$tmp/x.glb" --memory 1G
expect_exit 2 "mesh --memory (bad size)" "$bin" mesh "$tmp/holed.csg" -o "$tmp/x.ply" --memory 12Q
expect_exit 1 "mesh --memory (below the process itself)" "$bin" mesh "$tmp/holed.csg" -o "$tmp/x.ply" --memory 1M
grep -q "give at least" "$tmp/err" && ok || bad "mesh --memory 1M: no message saying what is needed"
expect_exit 1 "mesh --memory (a slab outgrows it)" "$bin" mesh --shape "sphere(r=1)" --voxel 0.001 -o "$tmp/x.ply" --memory 120M
grep -q "raise --memory" "$tmp/err" && ok || bad "mesh --memory: no advice when a slab outgrows the limit"
[ ! -e "$tmp/x.ply" ] && ok || bad "mesh --memory: a partial output was left"
ls -a "$tmp" | grep -q scratch && bad "mesh --memory: scratch files left behind" || ok
# Volumes with --memory: a real CT (NRRD) converted a slab at a time, and a .vdb grid, the same bytes.
ct="$shared/volumes/headsq-ct-nrrd/quarter.nhdr"
if [ -f "$ct" ]; then
    # The reference: the whole volume's grid (convert's, as the in-memory path makes it) meshed from a .vdb.
    "$bin" --quiet convert "$ct" -o "$tmp/ct.vdb" && "$bin" --quiet mesh "$tmp/ct.vdb" --iso 1000 --normals -o "$tmp/ct_whole.ply"
    expect_exit 0 "mesh CT (streamed by default)" "$bin" mesh "$ct" --iso 1000 --normals -o "$tmp/ct_streamed.ply"
    grep -q "in 1 pass over the file" "$tmp/out" && ok || { bad "mesh CT: not streamed"; cat "$tmp/out"; }
    # The summary: what was read, as the in-memory path says it, and a limit chosen for the user.
    grep -q "int16 voxels, spacing 3.2 x 3.2 x 1.5 mm, LPS, values 0 .. 3926, in 1 pass" "$tmp/out" && ok \
        || { bad "mesh CT (streamed): the reading line lacks spacing, orientation or range"; cat "$tmp/out"; }
    grep -q "^peak memory .* (within half of this machine's memory, " "$tmp/out" && ok \
        || { bad "mesh CT (streamed): the summary does not say the limit was chosen"; cat "$tmp/out"; }
    cmp -s "$tmp/ct_whole.ply" "$tmp/ct_streamed.ply" && ok || bad "mesh CT (streamed): not the whole grid's bytes"
    expect_exit 0 "mesh CT --read-whole" "$bin" mesh "$ct" --iso 1000 --normals -o "$tmp/ct_read.ply" --read-whole
    grep -q "pass over the file" "$tmp/out" && bad "mesh CT --read-whole: streamed" || ok
    cmp -s "$tmp/ct_whole.ply" "$tmp/ct_read.ply" && ok || bad "mesh CT --read-whole: not the whole grid's bytes"
    expect_exit 2 "mesh --read-whole --memory" "$bin" mesh "$ct" --iso 1000 -o "$tmp/x.ply" --read-whole --memory 1G
    expect_exit 2 "mesh --read-whole of a field" "$bin" mesh --shape "sphere(r=1)" -o "$tmp/x.ply" --read-whole
    expect_exit 0 "mesh CT --memory" "$bin" mesh "$ct" --iso 1000 --normals -o "$tmp/ct_slabs.ply" --memory 500M
    cmp -s "$tmp/ct_whole.ply" "$tmp/ct_slabs.ply" && ok || bad "mesh CT --memory: not the whole grid's bytes"
    grep -q "^peak memory .* (limit 500 MiB; " "$tmp/out" && ok || { bad "mesh CT --memory: no limit in the summary"; cat "$tmp/out"; }
    # Inside below, where the exterior is the volume's minimum (inside) as in the whole grid.
    "$bin" --quiet mesh "$tmp/ct.vdb" --iso 1000 --inside below -o "$tmp/ct_below_whole.ply"
    expect_exit 0 "mesh CT --inside below (streamed)" "$bin" mesh "$ct" --iso 1000 --inside below -o "$tmp/ct_below.ply"
    cmp -s "$tmp/ct_below_whole.ply" "$tmp/ct_below.ply" && ok || bad "mesh CT --inside below: not the whole grid's bytes"
    # To .glb (which does not stream) the volume is read whole, and only its blocks near the level kept.
    "$bin" --quiet mesh "$tmp/ct.vdb" --iso 1000 -o "$tmp/ct_whole.glb"
    expect_exit 0 "mesh CT to .glb (read whole)" "$bin" mesh "$ct" --iso 1000 -o "$tmp/ct.glb"
    cmp -s "$tmp/ct_whole.glb" "$tmp/ct.glb" && ok || bad "mesh CT to .glb: not the whole grid's bytes"
    rm -f "$tmp/ct.vdb"
fi
# A DICOM series that fits is read whole, but only its blocks near the iso-value become a grid: the whole
# grid's bytes. With --memory its slices stream from the reading helper one at a time: the same bytes.
dicom="$shared/volumes/ct-abdomen-dicom/series"
if [ -d "$dicom" ]; then
    "$bin" --quiet convert "$dicom" -o "$tmp/abd.vdb"
    for side in above below; do
        "$bin" --quiet mesh "$tmp/abd.vdb" --iso 300 --inside $side --normals -o "$tmp/abd_whole.ply"
        expect_exit 0 "mesh DICOM --inside $side" "$bin" mesh "$dicom" --iso 300 --inside $side --normals -o "$tmp/abd.ply"
        cmp -s "$tmp/abd_whole.ply" "$tmp/abd.ply" && ok || bad "mesh DICOM --inside $side: not the whole grid's bytes"
        expect_exit 0 "mesh DICOM --inside $side --memory 150M" "$bin" mesh "$dicom" --iso 300 --inside $side --normals \
            -o "$tmp/abd.ply" --memory 150M
        cmp -s "$tmp/abd_whole.ply" "$tmp/abd.ply" && ok || bad "mesh DICOM --memory: not the whole grid's bytes"
        grep -q "(DICOM, 48 files): 512 x 512 x 48 uint16 voxels.*HU, in 1 pass over the files" "$tmp/out" && ok \
            || { bad "mesh DICOM --memory: not streamed"; cat "$tmp/out"; }
    done
    rm -f "$tmp/abd.vdb"
    # A slice of another size in the middle of the series (its Rows, at byte 2272 of 1-070.dcm, made 256):
    # the header pass reads only the first slice, so the stream meets it; its error names it, no file is left.
    mkdir -p "$tmp/odd"
    cp "$dicom"/*.dcm "$tmp/odd/" && chmod u+w "$tmp"/odd/*.dcm
    printf '\x00\x01' | dd of="$tmp/odd/1-070.dcm" bs=1 seek=2272 conv=notrunc 2>/dev/null
    expect_exit 1 "mesh DICOM --memory, an odd slice" "$bin" mesh "$tmp/odd" --iso 300 -o "$tmp/odd.ply" --memory 150M
    grep -q "1-070.dcm: 512 x 256 pixels, but the series' slices are 512 x 512" "$tmp/err" && ok \
        || { bad "mesh DICOM --memory, odd slice: the error does not name it"; cat "$tmp/err"; }
    [ ! -e "$tmp/odd.ply" ] && ok || bad "mesh DICOM --memory, odd slice: a partial output was left"
    rm -rf "$tmp/odd"
    expect_exit 2 "mesh CT --memory --smooth" "$bin" mesh "$ct" --iso 1000 --smooth 1 -o "$tmp/x.ply" --memory 500M
fi
# A volume file streamed (never whole), keeping only the blocks near the iso-value: the same bytes, under
# the limit, where the in-memory path holds the whole volume (a 1237 x 159 x 159 float NIfTI: 125 MB).
printf 'difference() { cube([8, 1, 1], center = true); rotate([0, 90, 0]) cylinder(h = 9, r = 0.3, center = true); }\n' >"$tmp/wide.isf"
"$bin" --quiet sample "$tmp/wide.isf" --voxel 0.0065 -o "$tmp/wide.vdb" && "$bin" --quiet convert "$tmp/wide.vdb" -o "$tmp/wide.nii"
"$bin" --quiet convert "$tmp/wide.nii" -o "$tmp/wide_grid.vdb" && "$bin" --quiet mesh "$tmp/wide_grid.vdb" --normals -o "$tmp/wide_whole.ply"
rm -f "$tmp/wide_grid.vdb"
for limit in 150 125; do  # 46 MiB of grid near the level: one pass or two, as the limit leaves room
    expect_exit 0 "mesh NIfTI --memory ${limit}M (streamed)" "$bin" mesh "$tmp/wide.nii" --normals -o "$tmp/wide_slabs.ply" --memory ${limit}M
    cmp -s "$tmp/wide_whole.ply" "$tmp/wide_slabs.ply" && ok || bad "mesh NIfTI --memory ${limit}M: not the in-memory path's bytes"
    grep -Eq "in [0-9]+ pass(es)? over the file \([0-9]+ MiB of slices and a grid of [0-9]+ MiB near the iso-value" "$tmp/out" && ok \
        || { bad "mesh NIfTI --memory ${limit}M: no reading line"; cat "$tmp/out"; }
    awk -v m=$limit '/^peak memory/ { v = $3; gsub(",", "", v); exit !(v + 0 > 0 && v + 0 <= m) }' "$tmp/out" && ok \
        || { bad "mesh NIfTI --memory ${limit}M: peak memory not under the limit"; cat "$tmp/out"; }
done
rm -f "$tmp/wide.nii" "$tmp/wide.vdb"
# Thirteen slices of a 1024 x 1024 raw volume (53 MiB) and the process do not fit in 130M: refused with the figure.
truncate -s $((1024 * 1024 * 16)) "$tmp/zeros.raw"
expect_exit 1 "mesh volume --memory (its slices cannot fit)" "$bin" mesh "$tmp/zeros.raw" --dims 1024,1024,16 --type uint8 --iso 0.5 -o "$tmp/x.ply" --memory 130M
grep -q "raise --memory to at least" "$tmp/err" && ok || { bad "mesh volume --memory: no estimate when its slices cannot fit"; cat "$tmp/err"; }
[ ! -e "$tmp/x.ply" ] && ok || bad "mesh volume --memory: a partial output was left"
rm -f "$tmp/zeros.raw"
"$bin" --quiet mesh "$src/data/sphere.vdb" -o "$tmp/vdb_whole.stl"
expect_exit 0 "mesh .vdb --memory" "$bin" mesh "$src/data/sphere.vdb" -o "$tmp/vdb_slabs.stl" --memory 500M
cmp -s "$tmp/vdb_whole.stl" "$tmp/vdb_slabs.stl" && ok || bad "mesh .vdb --memory: not the in-memory path's bytes"

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
