#!/usr/bin/env bash
# The main job on bundled data: render the showcase scene (CSG + blobby + quadric, materials, shadows)
# both ways, mesh the bundled level set and a scene, and check the meshes. Outputs go to out/.
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
echo "demo: images and meshes are in out/ (open out/showcase.png)"
