#!/usr/bin/env bash
# Installs everything isoforge needs on Debian 12 (bookworm): the toolchain and the libraries.
# Idempotent and non-interactive: does nothing when all packages are present.
set -euo pipefail

packages=(
  # toolchain
  g++ cmake ninja-build git pkg-config ca-certificates
  # libraries
  libopenvdb-dev libboost-iostreams-dev libtbb-dev libembree-dev libopenimageio-dev libglm-dev zlib1g-dev
  libcli11-dev libmeshoptimizer-dev libtinygltf-dev
  # PNG written straight through libpng (render/png_writer.cpp), other image formats through OpenImageIO
  libpng-dev
  # Clipper 6.4, as OpenSCAD 2021.01 uses it for 2D booleans (twisted extrusions of OpenSCAD models)
  libpolyclipping-dev
  # exact predicates for the self-intersection check and convex hulls (mesh/), OpenSCAD's hull and minkowski
  libcgal-dev
  # text(): the font libraries OpenSCAD renders text with (csg/text.cpp), and a font for its default
  libfreetype-dev libharfbuzz-dev libfontconfig-dev fonts-dejavu-core
  # medical volumes: NIfTI (niftilib), DICOM (GDCM), NRRD (teem)
  libnifti2-dev libgdcm-dev libteem-dev
  # OpenImageIO's CMake export names its command-line tools, so they must exist
  openimageio-tools
  # OpenVDB's own tools (vdb_print, vdb_render) for comparisons
  libopenvdb-tools
  # OpenSCAD models (.scad input runs openscad) and its regression corpus (tests and bench/openscad_corpus.py)
  openscad openscad-testing-data
  # isoforge view: its HTTP server (cpp-httplib), three.js for the page, and headless Chromium for its test
  libcpp-httplib-dev libjs-three chromium
  # many machines: isoforge-mpi (mpi/, docs/scaling.md) on OpenMPI
  libopenmpi-dev openmpi-bin
  # tests and benchmarks
  libgtest-dev libbenchmark-dev
  # the Python package (python/, docs/python.md) and its tests; scikit-image is the baseline of
  # bench/python_marching_cubes.py and of one test (and bench/vm_numpy.py uses numpy)
  pybind11-dev python3-dev python3-numpy python3-pytest python3-skimage
)
# CI also checks formatting and fuzzes the scene parser (clang + libFuzzer).
if [ "${ISOFORGE_CI:-}" = 1 ]; then packages+=(clang-format clang libclang-rt-14-dev); fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages are installed"
  exit 0
fi

as_root=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup: run as root or install sudo" >&2; exit 1; }
  as_root=(sudo)
fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${as_root[@]}" apt-get update -q
"${as_root[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
