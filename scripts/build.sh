#!/usr/bin/env bash
# Configures and builds isoforge in Release into build/ (ninja). Extra arguments go to CMake.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build build
# `import isoforge` for Debian's python3 (docs/python.md): a .pth file naming build/python in its user site
# directory. Only when the package was built (pybind11 found) and that directory can be written.
if [ -f build/python/isoforge/__init__.py ] && [ -x /usr/bin/python3 ]; then
  site=$(/usr/bin/python3 -m site --user-site 2>/dev/null || true)
  if [ -n "$site" ] && mkdir -p "$site" 2>/dev/null; then
    echo "$PWD/build/python" > "$site/isoforge.pth"
  fi
fi
