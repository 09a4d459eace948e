#!/usr/bin/env bash
# The main job on bundled data: render the showcase scene (CSG + blobby + quadric, materials, shadows)
# both ways, mesh the bundled level set and a scene, render and mesh a bundled CT head, and check the
# meshes. Outputs go to out/.
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p out
bin=build/app/isoforge
$bin render examples/showcase.isf --spp 4 -o out/showcase.png
$bin render examples/showcase.isf --method march --size 512x384 -o out/showcase_march.png
$bin info data/sphere.vdb
$bin mesh data/sphere.vdb -o out/sphere.ply
$bin check out/sphere.ply
$bin mesh examples/bracket.isf -o out/bracket.ply
$bin check --strict out/bracket.ply
# A CT of a head (NRRD, 93 slice files): bone under translucent skin, a bone mesh, a slice.
$bin info data/headsq/quarter.nhdr
$bin render data/headsq/quarter.nhdr --iso 1150:ivory --iso 500:skin:0.35 --up 0,0,-1 --size 800x600 -o out/head.png
$bin mesh data/headsq/quarter.nhdr --iso 1150 --smooth 1 -o out/head_bone.ply
$bin check --strict out/head_bone.ply
$bin slice data/headsq/quarter.nhdr --axis axial --index 40 -o out/head_slice.png
# The same from Python (docs/python.md), where the package was built: a CSG part, meshed and checked.
if [ -f build/python/isoforge/__init__.py ]; then
  PYTHONPATH=build/python /usr/bin/python3 -c '
import isoforge as iso
f = (iso.box(2) - iso.cylinder(r=0.4, h=3)) | iso.sphere(0.8).translate((0, 0, 1))
m = iso.smooth_union(f, iso.torus(1, 0.2), k=0.1).mesh(voxel=0.02)
m.save("out/python_part.glb")
r = m.check()
print("python: %d triangles, closed %s, genus %s -> out/python_part.glb" % (len(m), r["valid_closed_surface"], r["genus"]))'
fi
echo "demo: images and meshes are in out/ (open out/showcase.png and out/head.png)"
