#!/usr/bin/python3
"""Sharp features: isoforge mesh (plain marching cubes and --sharp) against OpenSCAD's exact mesh.

For each model (bench/sharp/*.scad and OpenSCAD's example001 at $fn = 96): `openscad -o ref.stl`, then
`isoforge mesh model.scad --resolution 256` with --no-sharp, --sharp, and --sharp --max-error of a quarter voxel
("simplified"), `isoforge compare` against the
reference (distance of points sampled on the reference's sharp edges to our mesh, Hausdorff, mean surface
distance, in voxels) and `isoforge check --self-intersections`. Prints a Markdown table.

  bench/sharp_fidelity.py [--isoforge PATH] [--resolution N] [--modes plain,sharp,simplified] [model.scad ...]
"""
import argparse
import glob
import os
import re
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def run(cmd):
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), p.stdout + p.stderr))
    return p.stdout + p.stderr, time.perf_counter() - t


def bounds_of_stl(path):
    lo, hi = [1e30] * 3, [-1e30] * 3
    for m in re.finditer(rb"vertex\s+(\S+)\s+(\S+)\s+(\S+)", open(path, "rb").read()):
        for k in range(3):
            v = float(m.group(k + 1))
            lo[k], hi[k] = min(lo[k], v), max(hi[k], v)
    return lo, hi


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--isoforge", default=os.path.join(ROOT, "build/app/isoforge"))
    ap.add_argument("--resolution", type=int, default=256)
    ap.add_argument("--modes", default="plain,sharp,simplified")
    ap.add_argument("models", nargs="*")
    args = ap.parse_args()
    models = args.models or sorted(glob.glob(os.path.join(HERE, "sharp/*.scad"))) + [
        "/usr/share/openscad/examples/Old/example001.scad"]
    tmp = tempfile.mkdtemp(prefix="sharp-")
    print("| model | mode | triangles | sharp edges mean / p90 (voxels) | Hausdorff (voxels) | "
          "mean distance (voxels) | self-intersecting pairs | mesh s |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for model in models:
        name = os.path.splitext(os.path.basename(model))[0]
        defs = ["-D", "$fn=96"] if "example001" in model else []
        ref = os.path.join(tmp, name + ".stl")
        run(["openscad", "-o", ref] + defs + [model])
        lo, hi = bounds_of_stl(ref)
        voxel = max(h - l for l, h in zip(lo, hi)) / args.resolution
        for mode in args.modes.split(","):
            out = os.path.join(tmp, "%s_%s.ply" % (name, mode))
            cmd = [args.isoforge, "mesh", model, "--voxel", repr(voxel), "-o", out, "--quiet"]
            cmd += [a for d in zip(["-D"] * (len(defs) // 2), defs[1::2]) for a in d]
            # Both modes named: OpenSCAD models get feature vertices by default.
            cmd.append("--no-sharp" if mode == "plain" else "--sharp")
            if mode == "simplified":
                cmd += ["--max-error", repr(voxel / 4)]
            _, seconds = run(cmd)
            cmp, _ = run([args.isoforge, "compare", out, ref, "--voxel", repr(voxel)])
            chk, _ = run([args.isoforge, "check", out, "--self-intersections"])
            tri = re.search(r"triangles\s+(\d+)", cmp).group(1)
            edge = re.search(r"sharp edges\s+mean (\S+)\s+p90 (\S+)", cmp)
            haus = re.search(r"hausdorff\s+(\S+)", cmp).group(1)
            mean = re.search(r"from reference\s+mean (\S+)", cmp).group(1)
            si = re.search(r"self-intersect\s+(.*)", chk).group(1)
            si = "0" if si.startswith("none") else re.search(r"YES: (\d+)", si).group(1)
            print("| %s | %s | %s | %s / %s | %s | %s | %s | %.2f |" % (
                name, mode, f"{int(tri):,}", edge.group(1) if edge else "-", edge.group(2) if edge else "-", haus,
                mean, si, seconds), flush=True)


if __name__ == "__main__":
    main()
