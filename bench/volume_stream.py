#!/usr/bin/python3
"""Volume files meshed as they stream (issue #19, docs/scaling.md "Volumes"), whole commands.

A CT larger than the bundled one, made from it: the abdominal DICOM series (512 x 512 x 48, real HU),
upsampled in x and y by repetition and stacked along z with every other copy mirrored, written as
int16 raw data with a MetaImage header (`.mhd`, which VTK's reader takes too; isoforge streams NRRD's
and NIfTI's the same way). Then, on the same file, bone at 300 HU to binary PLY:

1. `isoforge mesh CT.mhd --iso 300 -o bone.ply` (streamed, the default for such a file), and with
   `--memory` small enough to take several passes;
2. the whole volume's grid in memory: `isoforge convert CT.mhd -o CT.vdb`, then `isoforge mesh CT.vdb`
   (the path that reads the volume whole); the two meshes must be the same bytes;
3. VTK 9 (Debian python3-vtk9): vtkMetaImageReader, vtkFlyingEdges3D, vtkPLYWriter, as one process.

Wall seconds and peak resident memory of each whole process (/usr/bin/time).

  bench/volume_stream.py [--build DIR] [--quick] [--huge]
      --quick: 512 x 512 x 192 (100 MB); default 1024 x 1024 x 768 (1.6 GB);
      --huge: also 1024 x 1024 x 6528 (13.7 GB, 25.5 GiB as floats: more than a 24 GB machine holds;
              streamed rows only)
"""
import argparse
import filecmp
import os
import re
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SERIES = os.path.join(ROOT, "..", "shared", "data", "volumes", "ct-abdomen-dicom", "series")

VTK_JOB = r"""
import sys, vtk
r = vtk.vtkMetaImageReader(); r.SetFileName(sys.argv[1]); r.Update()
fe = vtk.vtkFlyingEdges3D(); fe.SetInputConnection(r.GetOutputPort()); fe.SetValue(0, 300.0)
fe.ComputeNormalsOff(); fe.ComputeGradientsOff(); fe.ComputeScalarsOff(); fe.Update()
w = vtk.vtkPLYWriter(); w.SetFileName(sys.argv[2]); w.SetFileTypeToBinary(); w.SetInputConnection(fe.GetOutputPort()); w.Write()
print("triangles", fe.GetOutput().GetNumberOfPolys())
"""


def timed(cmd):
    """Wall seconds, peak RSS in MiB and the output of a whole command."""
    p = subprocess.run(["/usr/bin/time", "-f", "TIME %e %M"] + cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), p.stdout + p.stderr))
    m = re.search(r"TIME ([\d.]+) (\d+)", p.stderr)
    return float(m.group(1)), int(m.group(2)) / 1024.0, p.stdout + p.stderr


def make_ct(isoforge, tmp, up, copies):
    """The bundled CT, upsampled by `up` in x and y and stacked `copies` times along z: a MetaImage."""
    nii = os.path.join(tmp, "ct.nii")
    subprocess.run([isoforge, "--quiet", "convert", SERIES, "-o", nii], check=True)
    b = open(nii, "rb").read()
    nx, ny, nz = [int(d) for d in np.frombuffer(b, "<i2", 3, 42)]
    spacing = np.frombuffer(b, "<f4", 3, 80)
    offset = int(np.frombuffer(b, "<f4", 1, 108)[0])
    v = np.frombuffer(b, "<f4", nx * ny * nz, offset).reshape(nz, ny, nx)
    v = np.round(v.repeat(up, axis=1).repeat(up, axis=2)).astype("<i2")
    os.remove(nii)
    name = "ct_%dx%dx%d" % (nx * up, ny * up, nz * copies)
    with open(os.path.join(tmp, name + ".raw"), "wb") as f:
        for c in range(copies):
            (v if c % 2 == 0 else v[::-1]).tofile(f)
    header = os.path.join(tmp, name + ".mhd")
    with open(header, "w") as f:
        f.write("ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
                "DimSize = %d %d %d\nElementSpacing = %g %g %g\nElementType = MET_SHORT\nElementDataFile = %s.raw\n"
                % (nx * up, ny * up, nz * copies, spacing[0] / up, spacing[1] / up, spacing[2], name))
    return header, os.path.join(tmp, name + ".raw")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--huge", action="store_true")
    args = ap.parse_args()
    isoforge = os.path.join(args.build, "app", "isoforge")
    try:
        import vtk  # noqa: F401
        have_vtk = True
    except ImportError:
        have_vtk = False
    sizes = [(1, 4)] if args.quick else [(2, 16)]
    if args.huge:
        sizes.append((2, 136))
    print("## Volume files to a bone mesh (300 HU, binary PLY), whole commands, %s cores\n" % os.cpu_count())
    print("| volume | command | s | peak MiB | triangles | same bytes as streamed | VTK s / isoforge s |")
    print("|---|---|---:|---:|---:|---|---:|")
    with tempfile.TemporaryDirectory(dir="/tmp") as tmp:
        for up, copies in sizes:
            header, raw = make_ct(isoforge, tmp, up, copies)
            name = os.path.basename(header)[:-4]
            size = "%s (%.1f GB int16)" % (name, os.path.getsize(raw) / 1e9)
            streamed = os.path.join(tmp, "streamed.ply")
            t, p, out = timed([isoforge, "mesh", header, "--iso", "300", "-o", streamed])
            tri = re.search(r"([\d,]+) triangles", out).group(1)
            rows = [("`isoforge mesh` (streamed)", t, p, tri, "-")]
            base = t
            limit = "160M" if args.quick else ("2G" if copies > 16 else "250M")
            other = os.path.join(tmp, "limited.ply")
            t, p, out = timed([isoforge, "mesh", header, "--iso", "300", "-o", other, "--memory", limit])
            passes = re.search(r"in ([\d,]+) pass", out).group(1)
            rows.append(("`--memory %s` (%s pass%s)" % (limit, passes, "" if passes == "1" else "es"), t, p, tri,
                         "yes" if filecmp.cmp(streamed, other, shallow=False) else "NO"))
            if os.path.getsize(raw) * 2 < 10e9:  # floats and their dense grid within this machine
                vdb = os.path.join(tmp, "ct.vdb")
                t1, p1, _ = timed([isoforge, "--quiet", "convert", header, "-o", vdb])
                t2, p2, _ = timed([isoforge, "mesh", vdb, "--iso", "300", "-o", other])
                rows.append(("whole grid: `convert` %.2f s + `mesh CT.vdb` %.2f s" % (t1, t2), t1 + t2, max(p1, p2),
                             tri, "yes" if filecmp.cmp(streamed, other, shallow=False) else "NO"))
                os.remove(vdb)
            if have_vtk and os.path.getsize(raw) * 2 < 10e9:
                t, p, out = timed(["/usr/bin/python3", "-c", VTK_JOB, header, other])
                vt = re.search(r"triangles (\d+)", out).group(1)
                rows.append(("VTK: vtkMetaImageReader + vtkFlyingEdges3D + vtkPLYWriter", t, p, format(int(vt), ","),
                             "-", "%.1fx" % (t / base)))
            for what, t, p, tri_, same, *ratio in rows:
                print("| %s | %s | %.2f | %.0f | %s | %s | %s |" % (size, what, t, p, tri_, same,
                                                                    ratio[0] if ratio else ""))
            for f in (header, raw, streamed, other):
                if os.path.exists(f):
                    os.remove(f)
    if not have_vtk:
        print("\n(VTK not installed: apt-get install python3-vtk9 for its rows)")


if __name__ == "__main__":
    main()
