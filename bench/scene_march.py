#!/usr/bin/env python3
"""Scenes by direct ray marching against the mesh path, whole commands as a user runs them.

For each bundled scene (examples/*.isf), an OpenSCAD export when one is given, and a generated 3D .vm
model of a few thousand statements:
  isoforge render X --method march --size WxH [--spp N] -o OUT.png   (the field's cell grid, then rays)
  isoforge render X --method mesh  --size WxH [--spp N] -o OUT.png   (sampling, meshing, Embree)
Prints a markdown table: whole-command seconds (median of --repeat runs), the frame's own seconds,
the grid's preparation and Mrays/s as the command's summary reports them, and march/mesh.

Usage: /usr/bin/python3 bench/scene_march.py [--build build] [--repeat 3] [--size 1024x768] [--spp 1]
                                             [--threads N] [extra inputs ...]
"""
import argparse
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def heavy_vm(path, balls=250):
    """A union of `balls` spheres on a spiral, as SSA statements (15 per ball): a 3D model of
    a few thousand statements, the kind the issue's .vm target is about."""
    lines = ["x var-x", "y var-y", "z var-z"]
    acc = None
    for i in range(balls):
        t = i / balls
        cx, cy, cz = 0.7 * (1 - t) * math.cos(40 * t), 0.7 * (1 - t) * math.sin(40 * t), 1.6 * t - 0.8
        r = 0.05 + 0.06 * (1 - t)
        p = f"b{i}_"
        lines += [
            f"{p}cx const {cx:.6f}", f"{p}cy const {cy:.6f}", f"{p}cz const {cz:.6f}", f"{p}r const {r:.6f}",
            f"{p}dx sub x {p}cx", f"{p}dy sub y {p}cy", f"{p}dz sub z {p}cz",
            f"{p}xx square {p}dx", f"{p}yy square {p}dy", f"{p}zz square {p}dz",
            f"{p}s1 add {p}xx {p}yy", f"{p}s2 add {p}s1 {p}zz", f"{p}d sqrt {p}s2", f"{p}v sub {p}d {p}r",
        ]
        if acc is None:
            acc = f"{p}v"
        else:
            lines.append(f"u{i} min {acc} {p}v")
            acc = f"u{i}"
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return len(lines)


def run(cmd):
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(" ".join(cmd) + " failed: " + p.stderr.strip())
    return dt, p.stdout + p.stderr


def summary(out):
    frame = re.search(r"frame ([0-9.]+) s \(([0-9.]+) Mrays/s\)", out)
    prep = re.search(r"(?:preparation|BVH) ([0-9.]+) s", out)
    return (float(frame.group(1)) if frame else float("nan"), float(frame.group(2)) if frame else float("nan"),
            float(prep.group(1)) if prep else 0.0)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--size", default="1024x768")
    ap.add_argument("--spp", type=int, default=1)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("inputs", nargs="*")
    a = ap.parse_args()
    exe = os.path.join(a.build, "app", "isoforge")
    tmp = tempfile.mkdtemp(prefix="isoforge-scene-march-")
    vm = os.path.join(tmp, "spiral_balls.vm")
    statements = heavy_vm(vm)
    inputs = sorted(os.path.join(ROOT, "examples", f) for f in os.listdir(os.path.join(ROOT, "examples"))
                    if f.endswith(".isf"))
    inputs += [vm] + a.inputs
    print(f"{a.size}, {a.spp} spp, shadows on, {a.threads or os.cpu_count()} threads; whole command = median of "
          f"{a.repeat}; the generated model {os.path.basename(vm)} has {statements} statements\n")
    print("| input | march: whole s | frame s | preparation s | Mrays/s | mesh: whole s | march / mesh |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for path in inputs:
        row = {}
        for method in ("march", "mesh"):
            cmd = [exe, "render", path, "--method", method, "--size", a.size, "--spp", str(a.spp),
                   "-o", os.path.join(tmp, f"out_{method}.png")]
            if a.threads:
                cmd += ["--threads", str(a.threads)]
            times, last = [], ""
            for _ in range(a.repeat):
                dt, last = run(cmd)
                times.append(dt)
            row[method] = (statistics.median(times),) + summary(last)
        m, e = row["march"], row["mesh"]
        print(f"| {os.path.basename(path)} | {m[0]:.2f} | {m[1]:.2f} | {m[3]:.2f} | {m[2]:.2f} | {e[0]:.2f} | "
              f"{m[0] / e[0]:.2f}x |")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
