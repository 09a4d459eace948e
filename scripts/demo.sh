#!/usr/bin/env bash
# The main job on bundled data: describe the bundled level set, mesh it, check the mesh.
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p out
build/app/isoforge info data/sphere.vdb
build/app/isoforge mesh data/sphere.vdb -o out/sphere.ply
build/app/isoforge check out/sphere.ply
