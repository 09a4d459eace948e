#!/usr/bin/env python3
"""Whole commands as a user runs them, side by side with OpenVDB's own tools on the same files and cameras.

Each row runs isoforge's command and the reference's alternately (A, B, A, B, ...: the machine's speed drifts),
as separate processes, timed from fork to exit, with each process's own peak memory (wait4's ru_maxrss):

  start-up      isoforge --help                      | vdb_print -version
  info          isoforge info data/sphere.vdb        | vdb_print data/sphere.vdb
  disk floor    cat big.vdb > /dev/null              (what reading the file can cost at best; page cache warm)
  mesh          isoforge mesh big.vdb -o out.ply     | vdb_tool -read big.vdb -ls2mesh adapt=0 -write out.ply
  render grid   isoforge render big.vdb --method march --size 1024x1024 --eye 0,-3.2,0.8 --target 0,0,0
                    --up 0,0,1 --fov 45 -o out.png   (shadows on)
                                                     | vdb_render big.vdb out.ppm -res 1024x1024 -translate
                    0,-3.2,0.8 -lookat 0,0,0 -up 0,0,1 -fov 45 -shader diffuse   (no shadows: it has none)
  render scene  isoforge render examples/showcase.isf --method march --size 1024x768
                                                     | the same with --method mesh (no outside tool renders it)
  render .vm    isoforge render spiral_balls.vm --method march --size 1024x1024
                                                     | the same with --method mesh

big.vdb is `isoforge sample --shape "sphere(r=1)" --voxel 1/R` (a level set of R voxels' radius, 400 by
default: the file of issue #18's figures); spiral_balls.vm is bench/scene_march.py's model (3,752 statements).
Prints a markdown table of medians (and the fastest run) and reference / isoforge.

Usage: /usr/bin/python3 bench/whole_commands.py [--build build] [--repeat 5] [--radius 400] [--only ROW ...]
"""
import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scene_march import heavy_vm  # noqa: E402  (the same generated model as the scene rows there)


def timed(cmd, shell=False):
    """Seconds from start to exit and the process's peak resident MiB; raises on failure."""
    # stderr to a file: a pipe nobody reads while we wait could fill and stall a chatty tool.
    with tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        p = subprocess.Popen(cmd, shell=shell, stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(p.pid, 0)
        dt = time.perf_counter() - t0
        p.returncode = code = os.waitstatus_to_exitcode(status)
        if code != 0:
            err.seek(0)
            text = err.read().decode(errors="replace").strip()[-500:]
            raise RuntimeError(f"{cmd if shell else ' '.join(cmd)} failed ({code}): {text}")
    return dt, usage.ru_maxrss / 1024.0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--radius", type=int, default=400, help="big.vdb's sphere radius in voxels")
    ap.add_argument("--only", nargs="*", default=[], help="rows by name: startup info floor mesh grid scene vm")
    a = ap.parse_args()
    exe = os.path.join(a.build, "app", "isoforge")
    for tool in ("vdb_print", "vdb_tool", "vdb_render"):
        if not shutil.which(tool):
            sys.exit(f"{tool} is not installed (Debian package openvdb-tools)")
    tmp = tempfile.mkdtemp(prefix="isoforge-whole-")
    big = os.path.join(tmp, "big.vdb")
    subprocess.run([exe, "sample", "--shape", "sphere(r=1)", "--voxel", repr(1.0 / a.radius), "-o", big, "--quiet"],
                   check=True)
    vm = os.path.join(tmp, "spiral_balls.vm")
    heavy_vm(vm)
    small = os.path.join(ROOT, "data", "sphere.vdb")
    showcase = os.path.join(ROOT, "examples", "showcase.isf")
    out = lambda name: os.path.join(tmp, name)  # noqa: E731
    camera = ["--eye", "0,-3.2,0.8", "--target", "0,0,0", "--up", "0,0,1", "--fov", "45"]
    rows = [
        ("startup", "start-up", [exe, "--help"], ["vdb_print", "-version"]),
        ("info", "info data/sphere.vdb", [exe, "info", small], ["vdb_print", small]),
        ("floor", "disk floor: cat big.vdb", f"cat {big} > /dev/null", None),
        ("mesh", "mesh big.vdb -> PLY", [exe, "mesh", big, "-o", out("a.ply"), "--quiet"],
         ["vdb_tool", "-read", big, "-ls2mesh", "adapt=0", "-write", out("b.ply")]),
        ("grid", "render big.vdb 1024x1024 (march, shadows)",
         [exe, "render", big, "--method", "march", "--size", "1024x1024", *camera, "-o", out("a.png"), "--quiet"],
         ["vdb_render", big, out("b.ppm"), "-res", "1024x1024", "-translate", "0,-3.2,0.8", "-lookat", "0,0,0",
          "-up", "0,0,1", "-fov", "45", "-shader", "diffuse"]),
        ("scene", "render showcase.isf 1024x768 (march vs mesh)",
         [exe, "render", showcase, "--method", "march", "--size", "1024x768", "-o", out("a.png"), "--quiet"],
         [exe, "render", showcase, "--method", "mesh", "--size", "1024x768", "-o", out("b.png"), "--quiet"]),
        ("vm", "render spiral_balls.vm 1024x1024 (march vs mesh)",
         [exe, "render", vm, "--method", "march", "--size", "1024x1024", "-o", out("a.png"), "--quiet"],
         [exe, "render", vm, "--method", "mesh", "--size", "1024x1024", "-o", out("b.png"), "--quiet"]),
    ]
    size = os.path.getsize(big) / 2**20
    print(f"big.vdb: sphere of {a.radius} voxels' radius, {size:.1f} MiB; {os.cpu_count()} cores; medians of "
          f"{a.repeat} alternating runs (fastest in brackets)\n")
    print("| command | isoforge s | peak MiB | reference s | peak MiB | reference / isoforge |")
    print("|---|---:|---:|---:|---:|---:|")
    commands = []
    for key, name, ours, ref in rows:
        if a.only and key not in a.only:
            continue
        shell = isinstance(ours, str)
        timed(ours, shell)  # warm the page cache and the loader's files
        if ref:
            timed(ref)
        t, m, rt, rm = [], [], [], []
        for _ in range(a.repeat):
            dt, mem = timed(ours, shell)
            t.append(dt)
            m.append(mem)
            if ref:
                dt, mem = timed(ref)
                rt.append(dt)
                rm.append(mem)
        cell = lambda ts: f"{statistics.median(ts):.3f} ({min(ts):.3f})"  # noqa: E731
        if ref:
            ratio = statistics.median(rt) / statistics.median(t)
            print(f"| {name} | {cell(t)} | {max(m):.0f} | {cell(rt)} | {max(rm):.0f} | {ratio:.2f}x |")
        else:
            print(f"| {name} | {cell(t)} | {max(m):.0f} | | | |")
        sys.stdout.flush()
        commands.append((ours if shell else " ".join(ours), " ".join(ref) if ref else ""))
    print("\nCommand lines (TMP = " + tmp + "):")
    for ours, ref in commands:
        print("  " + ours.replace(tmp, "TMP"))
        if ref:
            print("    vs " + ref.replace(tmp, "TMP"))
    shutil.rmtree(tmp)


if __name__ == "__main__":
    main()
