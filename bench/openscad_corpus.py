#!/usr/bin/python3
"""OpenSCAD compatibility corpus: real OpenSCAD models through isoforge, against OpenSCAD's own mesh.

For each .scad model: `openscad -o X.csg` and `openscad -o X.stl` (with -D '$fn=96' where the model
never sets $fn: isoforge meshes $fn = 0 primitives as exact smooth shapes, OpenSCAD as its default
facets), then `isoforge mesh X.csg --voxel <longest side of OpenSCAD's mesh / 256>`, timed as whole
commands. A model passes when isoforge's mesh is closed and oriented (wherever OpenSCAD's is closed),
its volume is within 0.5% of OpenSCAD's, each side of its bounding box within one voxel, and no two of its
triangles intersect (`isoforge check --self-intersections`, exact predicates; not timed).

  bench/openscad_corpus.py                       # the whole corpus (openscad-testing-data + examples)
  bench/openscad_corpus.py --fast                # the subset the tests run (tests/data/openscad_fast.txt)
  bench/openscad_corpus.py a.scad b.scad         # given models
Options: --isoforge PATH, --cache DIR (exports are kept there and reused), --timeout S (OpenSCAD's
STL export per model, default 120), --markdown (the table as Markdown, for docs/openscad.md), --no-sharp
(plain marching cubes instead of the default feature vertices).
Exit status: 0 when every supported model passes, 1 otherwise, 2 for a bad command line.
"""
import argparse
import glob
import hashlib
import json
import os
import re
import statistics
import struct
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SHARE = "/usr/share/openscad"
# Constructs isoforge refuses (docs/openscad.md): a model using one is listed as unsupported.
UNSUPPORTED = ["projection", "roof"]
# import() and surface() files isoforge reads (docs/openscad.md); other kinds make a model unsupported.
FILE_KINDS = {"import": (".stl", ".off", ".obj", ".ply"), "surface": (".dat",)}


def corpus():
    files = sorted(glob.glob(SHARE + "/testdata/scad/3D/*/*.scad")) + sorted(glob.glob(SHARE + "/examples/*/*.scad"))
    return files


def model_name(path):
    p = os.path.abspath(path)
    return p[len(SHARE) + 1:] if p.startswith(SHARE + "/") else os.path.basename(p)


def read_stl(path):
    data = open(path, "rb").read()
    if data[:5] == b"solid" and (b"facet" in data[:400] or b"endsolid" in data or len(data) < 84):
        v = np.array(re.findall(rb"vertex\s+(\S+)\s+(\S+)\s+(\S+)", data), dtype=np.float64)
        return v.reshape(-1, 3, 3)
    n = struct.unpack_from("<I", data, 80)[0]
    rec = np.frombuffer(data, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]), count=n,
                        offset=84)
    return rec["v"].astype(np.float64)


def read_ply(path):
    with open(path, "rb") as f:
        header = []
        while True:
            line = f.readline().decode("ascii").strip()
            header.append(line)
            if line == "end_header":
                break
        body = f.read()
    nv = nf = 0
    props = []
    section = None
    for line in header:
        w = line.split()
        if w[:2] == ["element", "vertex"]:
            nv, section = int(w[2]), "v"
        elif w[:2] == ["element", "face"]:
            nf, section = int(w[2]), "f"
        elif w[0] == "property" and section == "v":
            props.append(w[1])
    sizes = {"float": 4, "float32": 4, "uchar": 1, "uint8": 1, "double": 8}
    stride = sum(sizes[p] for p in props)
    raw = np.frombuffer(body, dtype=np.uint8, count=nv * stride).reshape(nv, stride)
    xyz = raw[:, :12].copy().view("<f4").reshape(nv, 3).astype(np.float64)
    faces = np.frombuffer(body, dtype=np.dtype([("c", "u1"), ("i", "<i4", 3)]), count=nf, offset=nv * stride)
    return xyz[faces["i"]]


def volume(tris):
    return float(np.sum(np.einsum("ij,ij->i", tris[:, 0], np.cross(tris[:, 1], tris[:, 2])))) / 6.0


def closed(tris):
    """Every edge used exactly twice, in opposite directions (points welded by position)."""
    if len(tris) == 0:
        return False
    pts, idx = np.unique(tris.reshape(-1, 3), axis=0, return_inverse=True)
    idx = idx.reshape(-1, 3)
    e = np.concatenate([idx[:, [0, 1]], idx[:, [1, 2]], idx[:, [2, 0]]])
    e = e[e[:, 0] != e[:, 1]]
    fwd = {tuple(x) for x in e.tolist()}
    if len(fwd) != len(e):
        return False
    return all((b, a) in fwd for a, b in fwd)


def run(cmd, timeout):
    t = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        return p.returncode, p.stdout + p.stderr, time.perf_counter() - t
    except subprocess.TimeoutExpired:
        return None, "timed out", time.perf_counter() - t


def export(scad, cache, timeout):
    """OpenSCAD's CSG and STL of a model (cached by content), with the STL export's time."""
    src = open(scad, "rb").read()
    sets_fn = b"$fn" in src
    key = hashlib.sha1(src + scad.encode()).hexdigest()[:12]
    base = os.path.join(cache, re.sub(r"[^A-Za-z0-9_.-]", "_", model_name(scad))[:-5] + "-" + key)
    meta = base + ".json"
    if os.path.exists(meta):
        return base, json.load(open(meta))
    defs = [] if sets_fn else ["-D", "$fn=96"]
    cwd = os.path.dirname(os.path.abspath(scad))
    for ext in (".csg", ".stl"):
        if os.path.exists(base + ext):
            os.remove(base + ext)
    rc, log, _ = run(["openscad", "-o", base + ".csg"] + defs + [os.path.abspath(scad)], 60)
    info = {"csg_rc": rc, "fn96": not sets_fn}
    if rc == 0:
        rc2, log2, t = run(["openscad", "-o", base + ".stl"] + defs + [os.path.abspath(scad)], timeout)
        info.update(stl_rc=rc2, openscad_s=t, stl_log=log2[-2000:], stl=os.path.exists(base + ".stl"))
    json.dump(info, open(meta, "w"))
    del cwd
    return base, info


def check_model(scad, args):
    base, info = export(scad, args.cache, args.timeout)
    row = {"model": model_name(scad), "status": "", "openscad_s": info.get("openscad_s"), "isoforge_s": None,
           "vol_err": None, "bbox_vox": None, "closed": None}
    if info["csg_rc"] != 0:
        row["status"] = "openscad fails (csg)"
        return row
    csg = open(base + ".csg").read()
    used = [u for u in UNSUPPORTED if re.search(r"\b" + u + r"\s*\(", csg)]
    # Files named by import() and surface() are relative to the model: the export, kept in the cache,
    # gets absolute paths. Missing ones stay (OpenSCAD and isoforge both skip them with a warning).
    model_dir = os.path.dirname(os.path.abspath(scad))
    for call, name in re.findall(r'\b(import|surface)\(file = "([^"]*)"', csg):
        ext = os.path.splitext(name)[1].lower()
        if name and os.path.exists(os.path.join(model_dir, name)) and ext not in FILE_KINDS[call]:
            used.append("%s %s" % (call, ext[1:].upper() or "file"))
    csg = re.sub(r'\b(import|surface)\(file = "([^"/][^"]*)"',
                 lambda m: '%s(file = "%s"' % (m.group(1), os.path.join(model_dir, m.group(2))), csg)
    if csg != open(base + ".csg").read():
        with open(base + ".abs.csg", "w") as f:
            f.write(csg)
    if re.search(r"_extrude\(file = ", csg):
        used.append("DXF import")
    if used:
        row["status"] = "unsupported: " + ", ".join(dict.fromkeys(used))
        return row
    if info.get("stl_rc") is None:
        row["status"] = "openscad timed out"
        return row
    if not info.get("stl"):
        log = info.get("stl_log", "")
        row["status"] = "2D or empty in openscad" if ("not a 3D object" in log or "empty" in log) else \
            "openscad fails (stl)"
        return row
    ref = read_stl(base + ".stl")
    if len(ref) == 0:
        row["status"] = "2D or empty in openscad"
        return row
    lo, hi = ref.reshape(-1, 3).min(0), ref.reshape(-1, 3).max(0)
    voxel = float(max(hi - lo)) / 256.0
    out = base + ".iso.ply"
    source = base + ".abs.csg" if os.path.exists(base + ".abs.csg") else base + ".csg"
    rc, log, t = run([args.isoforge, "mesh", source, "--voxel", "%.9g" % voxel, "-o", out, "--quiet"] +
                     (["--no-sharp"] if args.no_sharp else []), 600)
    row["isoforge_s"] = t
    if rc != 0:
        msg = log.strip().splitlines()[0] if log.strip() else ""
        row["status"] = "isoforge fails: " + msg.replace(source, "X.csg")[:200]
        return row
    mine = read_ply(out)
    # Exact predicates: intersecting triangle pairs (untimed).
    rc, log, _ = run([args.isoforge, "check", out, "--self-intersections"], 600)
    m = re.search(r"self-intersect\s+(none|YES: (\d+))", log)
    row["pairs"] = (0 if m.group(1) == "none" else int(m.group(2))) if m else None
    os.remove(out)
    vref, vmine = volume(ref), volume(mine) if len(mine) else 0.0
    row["vol_err"] = abs(vmine - vref) / abs(vref) if vref else float("inf")
    if len(mine):
        mlo, mhi = mine.reshape(-1, 3).min(0), mine.reshape(-1, 3).max(0)
        row["bbox_vox"] = float(max(np.max(np.abs(mlo - lo)), np.max(np.abs(mhi - hi)))) / voxel
    ref_closed = closed(ref)
    row["closed"] = closed(mine) if len(mine) else False
    if not ref_closed:
        # OpenSCAD wrote a mesh that is not a solid (faces kept flipped, or open): its volume means
        # nothing, so only the bounding box is compared.
        ok = row["bbox_vox"] is not None and row["bbox_vox"] <= 1.0 and row["closed"] and row["pairs"] == 0
        row["status"] = "pass (OpenSCAD's mesh open)" if ok else "FAIL (OpenSCAD's mesh open)"
        return row
    ok = row["vol_err"] <= 0.005 and row["bbox_vox"] is not None and row["bbox_vox"] <= 1.0 and \
        (row["closed"] or not ref_closed) and row["pairs"] == 0
    row["status"] = "pass" if ok else "FAIL"
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("models", nargs="*")
    ap.add_argument("--fast", action="store_true")
    ap.add_argument("--isoforge", default=os.path.join(ROOT, "build/app/isoforge"))
    ap.add_argument("--cache", default=os.path.join(ROOT, "build/openscad-corpus"))
    ap.add_argument("--timeout", type=float, default=120)
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--no-sharp", action="store_true")
    args = ap.parse_args()
    if subprocess.run(["which", "openscad"], capture_output=True).returncode != 0:
        print("openscad_corpus: openscad is not installed (Debian package openscad)", file=sys.stderr)
        return 2
    args.cache = os.path.abspath(args.cache)  # openscad writes a relative -o path beside the model
    os.makedirs(args.cache, exist_ok=True)
    # A copy of the executable, so that a rebuild during a long run does not pull it away.
    copy = os.path.join(args.cache, "isoforge.bench")
    subprocess.run(["cp", args.isoforge, copy], check=True)
    args.isoforge = copy
    models = args.models
    if args.fast:
        lst = os.path.join(ROOT, "tests/data/openscad_fast.txt")
        models = [os.path.join(SHARE, l.strip()) for l in open(lst) if l.strip() and not l.startswith("#")]
    if not models:
        models = corpus()
    rows = []
    for m in models:
        r = check_model(m, args)
        rows.append(r)
        f = lambda x, fmt: (fmt % x) if x is not None else "-"
        ratio = r["openscad_s"] / r["isoforge_s"] if r["openscad_s"] and r["isoforge_s"] else None
        if args.markdown:
            print("| %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
                r["model"], r["status"], f(r["openscad_s"], "%.2f"), f(r["isoforge_s"], "%.2f"), f(ratio, "%.1fx"),
                f(r["vol_err"] and 100 * r["vol_err"], "%.3f%%"), f(r["bbox_vox"], "%.2f"),
                {True: "yes", False: "no", None: "-"}[r["closed"]], f(r.get("pairs"), "%d")))
        else:
            print("%-60s %-28s openscad %7s s  isoforge %6s s  %7s  vol %8s  bbox %5s vox  closed %s  pairs %s" % (
                r["model"][:60], r["status"][:28], f(r["openscad_s"], "%.2f"), f(r["isoforge_s"], "%.2f"),
                f(ratio, "%.1fx"), f(r["vol_err"] and 100 * r["vol_err"], "%.3f%%"), f(r["bbox_vox"], "%.2f"),
                {True: "yes", False: "no", None: "-"}[r["closed"]], f(r.get("pairs"), "%d")), flush=True)
    meshed = [r for r in rows if r["status"].startswith(("pass", "FAIL", "isoforge fails"))]
    passed = [r for r in meshed if r["status"].startswith("pass")]
    ratios = [r["openscad_s"] / r["isoforge_s"] for r in meshed if r["openscad_s"] and r["isoforge_s"]]
    print("\n%d models: %d meshed by both, %d pass, %d fail; %d unsupported, %d 2D/empty or failing in OpenSCAD" % (
        len(rows), len(meshed), len(passed), len(meshed) - len(passed),
        sum(r["status"].startswith("unsupported") for r in rows),
        len(rows) - len(meshed) - sum(r["status"].startswith("unsupported") for r in rows)))
    if ratios:
        times = [r["isoforge_s"] for r in meshed if r["isoforge_s"]]
        slowest = max(meshed, key=lambda r: r["isoforge_s"] or 0)
        print("OpenSCAD time / isoforge time: median %.1fx, lowest %.1fx; isoforge slowest %.2f s (%s), median %.2f s"
              % (statistics.median(ratios), min(ratios), slowest["isoforge_s"], slowest["model"],
                 statistics.median(times)))
    return 0 if len(passed) == len(meshed) else 1


if __name__ == "__main__":
    sys.exit(main())
