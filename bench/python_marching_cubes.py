#!/usr/bin/env python3
"""isoforge's Python package beside scikit-image on the same arrays, whole calls as a user makes them.

  1. iso.marching_cubes(vol, level) vs skimage.measure.marching_cubes(vol, level) on real scans read
     through iso.read_volume (the bundled CT head; ../shared/data's abdominal CT and colin27 MR brain when
     present), on a ball of radius N/3 in N^3 (a smooth closed surface) and on a gyroid inside a ball
     (surface everywhere: the worst case for skipping empty space): time, triangles, closed and manifold
     or not, duplicate vertices (scikit-image repeats some).
  2. iso.sphere(1).mesh(resolution=N) vs the numpy way (fogleman/sdf's: sample the field on the dense
     N^3 grid with numpy, then skimage's marching cubes).
Prints a markdown table with the ratios. Usage: /usr/bin/python3 bench/python_marching_cubes.py [N ...]
(default 256 512). Needs python3-skimage, and build/python on PYTHONPATH (or the .pth of scripts/build.sh)."""
import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "build" / "python"))
import isoforge as iso  # noqa: E402
from skimage import measure  # noqa: E402


def gyroid(n):
    s = np.linspace(-1, 1, n, dtype=np.float32)
    z, y, x = np.meshgrid(s, s, s, indexing="ij")
    k = np.float32(6 * np.pi)
    g = np.sin(k * x) * np.cos(k * y) + np.sin(k * y) * np.cos(k * z) + np.sin(k * z) * np.cos(k * x)
    ball = np.float32(0.9) - np.sqrt(x * x + y * y + z * z)
    return np.minimum(np.float32(0.3) - np.abs(g), ball * 10).astype(np.float32)


def timed(f, repeat=3):
    best, out = float("inf"), None
    for _ in range(repeat):
        t = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t)
    return best, out


def facts(verts, faces):
    m = iso.Mesh(verts, faces)
    r = m.check()
    dup = len(verts) - len(np.unique(verts, axis=0))
    return len(faces), r["watertight"] and r["vertex_manifold"] and r["oriented"], dup


def row(name, t_iso, a, t_sk, b):
    ta, wa, da = a
    tb, wb, db = b
    print(f"| {name} | {t_iso:.3f} s | {t_sk:.3f} s | **{t_sk / t_iso:.1f}x** | {ta:,} / {tb:,} | "
          f"{'yes' if wa else 'no'} / {'yes' if wb else 'no'} | {da:,} / {db:,} |")


def ball(n):
    idx = np.linspace(-1.5, 1.5, n, dtype=np.float32)
    z, y, x = np.meshgrid(idx, idx, idx, indexing="ij")
    return (np.float32(1) - np.sqrt(x * x + y * y + z * z)).astype(np.float32)


def compare(name, vol, level, repeat):
    t1, (v1, f1, _, _) = timed(lambda: iso.marching_cubes(vol, level), repeat)
    t2, (v2, f2, _, _) = timed(lambda: measure.marching_cubes(vol, level), repeat)
    row(name, t1, facts(v1, f1), t2, facts(v2, f2))


def main():
    sizes = [int(a) for a in sys.argv[1:]] or [256, 512]
    print("| input | isoforge | scikit-image | ratio | triangles (iso / skimage) | closed and manifold | "
          "duplicate vertices |")
    print("|---|---|---|---|---|---|---|")
    shared = ROOT.parent / "shared" / "data" / "volumes"
    real = [(ROOT / "data/headsq/quarter.nhdr", 500.0, "CT head (bundled), skin"),
            (shared / "ct-abdomen-dicom/series", 300.0, "CT abdomen (DICOM), bone"),
            (shared / "colin27-mri-atlases/ch2.nii.gz", 60.0, "MR brain (colin27), level 60")]
    for path, level, name in real:
        if path.exists():
            vol, _ = iso.read_volume(str(path))  # Fortran order [i, j, k]: both take it as it is
            compare(f"{name} ({level:g}), {'x'.join(map(str, vol.shape))}", vol, level, 3)
    for n in sizes:  # a smooth closed surface: a ball of radius n/3, what organs and bones look like
        compare(f"ball of radius n/3, {n}^3", ball(n), 0.0, 3 if n <= 256 else 1)
    for n in sizes:
        compare(f"gyroid in a ball, {n}^3", gyroid(n), 0.0, 3 if n <= 256 else 1)
    for n in sizes:
        repeat = 3 if n <= 256 else 1
        t1, m = timed(lambda: iso.sphere(1).mesh(resolution=n), repeat)

        def numpy_way():
            s = np.linspace(-1.05, 1.05, n, dtype=np.float32)
            x, y, z = np.meshgrid(s, s, s, indexing="ij")
            d = np.sqrt(x * x + y * y + z * z) - np.float32(1)
            return measure.marching_cubes(d, 0.0, gradient_direction="ascent")

        t2, (v2, f2, _, _) = timed(numpy_way, repeat)
        row(f"sphere(1), {n} voxels across: `.mesh()` vs numpy sampling + skimage", t1,
            facts(m.vertices, m.triangles), t2, facts(v2, f2))


if __name__ == "__main__":
    main()
