#!/usr/bin/python3
"""Past one machine's memory and past one machine (issue #19, docs/scaling.md).

1. Out-of-core vs in-memory: `isoforge mesh --shape "sphere(r=1)" --voxel 1/R` with and without
   `--memory`, whole process: wall time, peak resident memory (/usr/bin/time), time per million
   triangles, and whether the two files are the same bytes (cmp). The largest size runs in slabs
   only (in memory it would not fit): 10^9 active voxels at R = 3650.
2. The OpenVDB anchor: createLevelSetSphere + volumeToMesh at the same radii (bench/openvdb_sphere_mesh).
3. Scaling of isoforge-mpi on this machine (mpirun --bind-to none, oversubscribed past the cores):
   strong (a fixed job, 1 and 2 ranks of one thread each, and 1..8 ranks of all threads) and weak (a
   surface growing with the rank count), with the time in MPI and the bytes the ranks exchanged.

  bench/scaling.py [--build DIR] [--quick] [--huge] [--repeat N] [--scaling-only]
"""
import argparse
import filecmp
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")


def timed(cmd):
    """Wall seconds, peak RSS in MiB and the output of a whole command."""
    p = subprocess.run(["/usr/bin/time", "-f", "TIME %e %M"] + cmd, capture_output=True, text=True, env=ENV)
    if p.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), p.stdout + p.stderr))
    m = re.search(r"TIME ([\d.]+) (\d+)", p.stderr)
    return float(m.group(1)), int(m.group(2)) / 1024.0, p.stdout + p.stderr


def triangles(text):
    m = re.search(r"([\d,]+) triangles", text)
    return int(m.group(1).replace(",", "")) if m else 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--quick", action="store_true", help="small sizes only (a minute)")
    ap.add_argument("--huge", action="store_true", help="also 10^9 active voxels (R = 3650; 13 GB of disk)")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each strong-scaling configuration (median)")
    ap.add_argument("--scaling-only", action="store_true", help="only the MPI tables")
    args = ap.parse_args()
    iso = os.path.join(args.build, "app", "isoforge")
    mpi = os.path.join(args.build, "mpi", "isoforge-mpi")
    anchor = os.path.join(args.build, "bench", "openvdb_sphere_mesh")
    tmp = tempfile.mkdtemp(prefix="isoforge-scaling-", dir=os.environ.get("TMPDIR", "/tmp"))
    radii = [250, 500] if args.quick else [500, 1000, 2000]

    if args.scaling_only:
        radii = []
    else:
        print("## Out-of-core vs in-memory (sphere(r=1) at voxel 1/R, whole process)\n")
        print("| R (voxels) | triangles | in memory: s, peak MiB | --memory 1G: s, peak MiB | s per M triangles (mem / slabs) | same bytes | OpenVDB createLevelSetSphere + volumeToMesh: s, peak MiB |")
        print("|---:|---:|---|---|---|---|---|")
    for r in radii:
        voxel = "%.9g" % (1.0 / r)
        a = os.path.join(tmp, "mem.ply")
        b = os.path.join(tmp, "slabs.ply")
        tm, pm, out = timed([iso, "mesh", "--shape", "sphere(r=1)", "--voxel", voxel, "-o", a])
        ts, ps, _ = timed([iso, "mesh", "--shape", "sphere(r=1)", "--voxel", voxel, "-o", b, "--memory", "1G"])
        n = triangles(out)
        same = filecmp.cmp(a, b, shallow=False)
        to, po, _ = timed([anchor, str(r)])
        print("| %d | %s | %.2f, %.0f | %.2f, %.0f | %.3f / %.3f | %s | %.2f, %.0f |" % (
            r, format(n, ","), tm, pm, ts, ps, tm / n * 1e6, ts / n * 1e6, "yes" if same else "NO", to, po))
        os.remove(a)
        os.remove(b)
    if args.huge and not args.scaling_only:
        b = os.path.join(tmp, "huge.ply")
        ts, ps, out = timed([iso, "mesh", "--shape", "sphere(r=1)", "--voxel", "%.9g" % (1 / 3650.0), "-o", b,
                             "--memory", "4G"])
        n = triangles(out)
        print("| 3650 (10^9 active voxels) | %s | (does not fit) | %.2f, %.0f (--memory 4G) | - / %.3f | - | - |" % (
            format(n, ","), ts, ps, ts / n * 1e6))
        os.remove(b)

    if not os.path.exists(mpi):
        print("\n(isoforge-mpi not built: no scaling table)")
        return
    r = 400 if args.quick else 1000
    job = ["mesh", "--shape", "sphere(r=1)", "--voxel", "%.9g" % (1.0 / r)]
    out_ply = os.path.join(tmp, "mpi.ply")
    print("\n## Strong scaling: isoforge-mpi on sphere(r=1) at R = %d (%s cores here)\n" % (r, os.cpu_count()))
    print("| ranks x threads | s | speed-up | MPI s | bytes exchanged | peak MiB of a rank |")
    print("|---|---:|---:|---:|---:|---:|")

    def mpirun(n, threads, cmd):
        extra = ["--threads", str(threads)] if threads else []
        t, p, out = timed(["mpirun", "--bind-to", "none", "--oversubscribe", "-np", str(n), mpi] + extra + cmd)
        m = re.search(r"MPI ([\d.]+) s, ([\d,]+) bytes exchanged; peak memory of a rank ([\d,]+) MiB", out)
        return t, float(m.group(1)), m.group(2), m.group(3)

    # Each configuration runs --repeat times, the configurations in turn (this machine's speed drifts by up
    # to 2x over minutes), and the median run is reported.
    configs = [(1, 1), (2, 1)] + [(k, 0) for k in ([1, 2, 4] if args.quick else [1, 2, 3, 4, 6, 8])]
    runs = {c: [] for c in configs}
    for _ in range(args.repeat):
        for c in configs:
            runs[c].append(mpirun(c[0], c[1], job + ["-o", out_ply]))
    base = None
    for n, threads in configs:
        t, ms, by, pk = sorted(runs[(n, threads)])[len(runs[(n, threads)]) // 2]
        if n == 1:
            base = t
        print("| %d x %s | %.2f | %.2fx | %.3f | %s | %s |" % (n, threads or "all", t, base / t, ms, by, pk))
    if args.repeat > 1:
        print("\n(medians of %d runs each, in turn; all runs, s: %s)" % (args.repeat, "; ".join(
            "%d x %s: %s" % (n, th or "all", ", ".join("%.2f" % r[0] for r in runs[(n, th)])) for n, th in configs)))

    print("\n## Weak scaling: the surface grows with the ranks (R = %d * sqrt(ranks)), oversubscribed\n" % (r // 2))
    print("| ranks | R | triangles | s | s per M triangles | MPI s | bytes exchanged |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for n in ([1, 2, 4] if args.quick else [1, 2, 4, 8]):
        rr = int(r // 2 * n ** 0.5)
        cmd = ["mesh", "--shape", "sphere(r=1)", "--voxel", "%.9g" % (1.0 / rr), "-o", out_ply]
        t, p, out = timed(["mpirun", "--bind-to", "none", "--oversubscribe", "-np", str(n), mpi] + cmd)
        m = re.search(r"MPI ([\d.]+) s, ([\d,]+) bytes exchanged", out)
        tri = triangles(out)
        print("| %d | %d | %s | %.2f | %.3f | %s | %s |" % (n, rr, format(tri, ","), t, t / tri * 1e6, m.group(1), m.group(2)))
    os.remove(out_ply)
    os.rmdir(tmp)


if __name__ == "__main__":
    main()
