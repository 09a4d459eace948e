#!/usr/bin/env bash
# isoforge-mpi end to end: the file is the serial path's bytes for 1, 2, 3 and 4 ranks (oversubscribed),
# for every output format, with surfaces on slab seams, empty slabs and ranks, colours and normals;
# a failing rank stops the job with exit 1 and no output; the .pvtp pieces hold the whole mesh.
# Usage: mpi_test.sh ISOFORGE ISOFORGE_MPI [--full]   (--full: larger jobs, up to 8 ranks)
set -u
bin=$1
mpibin=$2
full=${3:-}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# CI runs as root; OpenMPI refuses that unless told.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
run() { timeout 300 mpirun --oversubscribe -np "$@"; }

# Each rank's process is the launcher's program, started with malloc's huge pages (app/launcher.c).
run 2 "$mpibin" --version >"$tmp/out" 2>"$tmp/err"
[ $? -eq 0 ] && [ "$(grep -c '^isoforge-mpi ' "$tmp/out")" -eq 1 ] && ok || { bad "--version: not one answer"; cat "$tmp/out" "$tmp/err"; }
grep -q "malloc: GLIBC_TUNABLES=glibc.malloc.hugetlb=1$" "$tmp/out" && ok || bad "the launcher asks for huge pages"

ranks="1 2 3 4"
res=160
[ "$full" = --full ] && { ranks="1 2 3 4 5 6 7 8"; res=700; }

# A box whose faces lie on slab planes (1 unit = 128 voxels: iso values on the seams), a sphere tangent
# to them, objects far apart (slabs and ranks with nothing), colours from CSG colour nodes.
printf 'cube([2, 1.5, 1], center = true);\n' >"$tmp/seams.isf"
printf 'sphere(1); translate([8, 0, 0]) sphere(0.4); translate([-6, 1, 0]) color("red") cube(0.5);\n' >"$tmp/apart.isf"
printf 'color("red") difference() { cube(20, center = true); sphere(12); }\ntranslate([15, 0, 0]) color([0, 0, 1]) sphere(6);\n' >"$tmp/col.csg"
check() {  # name ext serial-args... -- shared args
    local name=$1 ext=$2
    shift 2
    "$bin" --quiet mesh "$@" -o "$tmp/serial.$ext" || { bad "$name: serial run failed"; return; }
    for n in $ranks; do
        run "$n" "$mpibin" --quiet mesh "$@" -o "$tmp/mpi.$ext" >"$tmp/out" 2>"$tmp/err" || { bad "$name: $n ranks failed"; cat "$tmp/err"; continue; }
        cmp -s "$tmp/serial.$ext" "$tmp/mpi.$ext" && ok || bad "$name: $n ranks differ from the serial file"
    done
}
check "seams (ply)" ply "$tmp/seams.isf" --voxel 0.0078125
check "apart (obj, normals)" obj "$tmp/apart.isf" --voxel 0.01 --normals
check "colours (ply)" ply "$tmp/col.csg" --no-sharp --resolution "$res"
check "torus (stl)" stl --shape "torus(R=1, r=0.3)" --resolution "$res"
check "quartic (ascii ply)" ply --expr "x^4+y^4+z^4-1" --box -2,-2,-2,2,2,2 --resolution "$res" --ascii
# A real CT series (512 x 512 x 48, four slabs): every rank reads it, each meshes its slabs.
ct="$(dirname "$0")/../../shared/data/volumes/ct-abdomen-dicom/series"
[ -d "$ct" ] && check "CT series (ply, normals)" ply "$ct" --iso 300 --normals
# A volume file each rank reads only its slabs of (MetaImage, zlib data): 500 columns, four slabs.
frog="$(dirname "$0")/../../shared/data/volumes/frog-tissue-labels/frogtissue.mhd"
[ -f "$frog" ] && check "frog labels read in slabs (stl)" stl "$frog" --iso 3.5
if [ "$full" = --full ]; then
    check "showcase (ply)" ply "$(dirname "$0")/../examples/showcase.isf" --resolution 1200
    check "sphere (ply, normals)" ply --shape "sphere(r=1)" --voxel 0.001 --normals
fi

# Failures: a bad input stops every rank (exit 1, one message, no file); a usage error is exit 2.
run 3 "$mpibin" mesh "$tmp/nope.isf" -o "$tmp/x.ply" >"$tmp/out" 2>"$tmp/err"
[ $? -eq 1 ] && ok || bad "missing input: not exit 1"
[ "$(grep -c 'isoforge-mpi: rank' "$tmp/err")" -eq 1 ] && ok || { bad "missing input: not one message"; cat "$tmp/err"; }
printf 'sphere(1);\ncube(;\n' >"$tmp/broken.isf"
run 2 "$mpibin" mesh "$tmp/broken.isf" -o "$tmp/x.ply" >"$tmp/out" 2>"$tmp/err"
[ $? -eq 1 ] && ok || bad "syntax error: not exit 1"
grep -q "broken.isf:2:" "$tmp/err" && ok || bad "syntax error: no file:line in the message"
run 2 "$mpibin" mesh "$tmp/seams.isf" -o "$tmp/x.glb" >"$tmp/out" 2>"$tmp/err"
[ $? -eq 2 ] && ok || bad ".glb output: not exit 2"
run 2 "$mpibin" mesh "$tmp/seams.isf" -o "$tmp/x.ply" --bogus >"$tmp/out" 2>"$tmp/err"
[ $? -eq 2 ] && ok || bad "unknown option: not exit 2"
# A rank that cannot write (a directory where the file goes): exit 1, nothing left behind.
mkdir -p "$tmp/ro" && chmod 555 "$tmp/ro"
if [ "$(id -u)" -ne 0 ]; then
    run 2 "$mpibin" mesh "$tmp/seams.isf" --voxel 0.02 -o "$tmp/ro/x.ply" >"$tmp/out" 2>"$tmp/err"
    [ $? -eq 1 ] && ok || bad "unwritable output: not exit 1"
fi
[ -z "$(ls -A "$tmp/ro")" ] && ok || bad "a failed job left files"
ls -a "$tmp" | grep -q 'mpi-.*tmp' && bad "temporary files left behind" || ok

# A rank killed while the file is written (SIGKILL on entering MPI_File_set_size, through MPI's profiling
# interface, PMPI): mpirun ends the other ranks with SIGTERM, and they remove the temporary file.
if command -v mpicc >/dev/null; then
    cat >"$tmp/killer.c" <<'C'
#include <mpi.h>
#include <signal.h>
#include <stdlib.h>
int MPI_File_set_size(MPI_File fh, MPI_Offset size) {
    int rank = 0;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    const char* r = getenv("ISOFORGE_KILL_RANK");
    if (r && atoi(r) == rank) raise(SIGKILL);
    return PMPI_File_set_size(fh, size);
}
C
    mpicc -shared -fPIC -o "$tmp/killer.so" "$tmp/killer.c" || bad "mpicc could not build the killer"
    for victim in 0 2; do
        mkdir -p "$tmp/killed"
        ISOFORGE_KILL_RANK=$victim run 3 -x ISOFORGE_KILL_RANK -x LD_PRELOAD="$tmp/killer.so" "$mpibin" --quiet mesh \
            "$tmp/seams.isf" --voxel 0.02 -o "$tmp/killed/x.ply" >"$tmp/out" 2>"$tmp/err"
        [ $? -ne 0 ] && ok || bad "rank $victim killed: the job did not fail"
        grep -q "signal 9" "$tmp/err" && ok || { bad "rank $victim killed: not killed where meant"; cat "$tmp/err"; }
        [ -z "$(ls -A "$tmp/killed")" ] && ok || { bad "rank $victim killed: files left"; ls -a "$tmp/killed"; }
        rm -rf "$tmp/killed"
    done
fi

# One piece per rank and a ParaView index: together the whole mesh (ghost vertices merged), read
# with VTK's own reader where python3-vtk9 is installed, else checked as XML.
"$bin" --quiet mesh "$tmp/apart.isf" --voxel 0.01 -o "$tmp/serial.ply"
run 3 "$mpibin" --quiet mesh "$tmp/apart.isf" --voxel 0.01 -o "$tmp/pieces.pvtp" || bad "pvtp: failed"
[ -f "$tmp/pieces_0.vtp" ] && [ -f "$tmp/pieces_2.vtp" ] && ok || bad "pvtp: pieces missing"
want=$(awk '/^element face/ { print $3 }' "$tmp/serial.ply")
/usr/bin/python3 - "$tmp/pieces.pvtp" "$want" <<'PY' && ok || bad "pvtp: the pieces are not the whole mesh"
import sys, os, re, xml.etree.ElementTree as ET
index, want = sys.argv[1], int(sys.argv[2])
try:
    import vtk
    r = vtk.vtkXMLPPolyDataReader(); r.SetFileName(index); r.Update()
    got = r.GetOutput().GetNumberOfCells()
except ImportError:  # the pieces' XML headers (their data is raw binary after <AppendedData>)
    got = 0
    for p in ET.parse(index).getroot().iter("Piece"):
        head = open(os.path.join(os.path.dirname(index), p.get("Source")), "rb").read().split(b"<AppendedData")[0]
        got += sum(int(n) for n in re.findall(rb'NumberOfPolys="(\d+)"', head))
print("pvtp triangles", got, "serial", want)
sys.exit(0 if got == want else 1)
PY

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
