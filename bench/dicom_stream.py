#!/usr/bin/python3
"""A DICOM series meshed read whole and streamed slice by slice (issue #19, docs/scaling.md), whole commands.

A series longer than the bundled one, made from it: the abdominal CT (512 x 512 x 48 slices, real HU)
repeated `--copies` times along z, each copy's slices moved down by the series' extent (their
ImagePositionPatient), with new SOPInstanceUIDs and instance numbers: real DICOM files that GDCM sorts
by position like any series. Then bone at 300 HU to binary PLY:

1. `isoforge mesh SERIES --iso 300 -o bone.ply --read-whole`: read whole (the default for series of up
   to 32 MiB of files), the helper sending the whole volume;
2. `isoforge mesh SERIES --iso 300 -o bone.ply`: streamed (the default above 32 MiB), the helper sending
   one slice at a time as the slab path asks for them (volume/near_level.h);
the two meshes must be the same bytes. Wall seconds and peak resident memory (/usr/bin/time: the
largest of isoforge and its helper).

  bench/dicom_stream.py [--build DIR] [--copies N] [--repeat R]
"""
import argparse
import filecmp
import os
import re
import struct
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SERIES = os.path.join(ROOT, "..", "shared", "data", "volumes", "ct-abdomen-dicom", "series")


def replace_element(data, group, element, value):
    """The first (implicit VR little endian) element (group, element) before the pixel data, with a new
    value (padded to even length with a space)."""
    if len(value) % 2:
        value += b" "
    tag = struct.pack("<HH", group, element)
    end = data.find(struct.pack("<HH", 0x7FE0, 0x0010))
    at = data.find(tag, 0, end)
    if at < 0:
        raise RuntimeError(f"no ({group:04x},{element:04x}) element")
    length = struct.unpack("<I", data[at + 4:at + 8])[0]
    return data[:at + 4] + struct.pack("<I", len(value)) + value + data[at + 8 + length:]


def element(data, group, element):
    end = data.find(struct.pack("<HH", 0x7FE0, 0x0010))
    at = data.find(struct.pack("<HH", group, element), 0, end)
    length = struct.unpack("<I", data[at + 4:at + 8])[0]
    return data[at + 8:at + 8 + length].rstrip(b" \0")


def make_series(out, copies):
    names = sorted(os.listdir(SERIES))
    files = [open(os.path.join(SERIES, n), "rb").read() for n in names]
    z = [float(element(f, 0x0020, 0x0032).split(b"\\")[2]) for f in files]
    extent = (max(z) - min(z)) * len(z) / (len(z) - 1)  # the series' length plus one spacing
    n = 0
    for c in range(copies):
        for f in files:
            x, y, zs = element(f, 0x0020, 0x0032).split(b"\\")
            position = b"\\".join([x, y, b"%.6f" % (float(zs) - c * extent)])
            g = replace_element(f, 0x0020, 0x0032, position)
            g = replace_element(g, 0x0008, 0x0018, b"1.2.826.0.1.3680043.9.7777.%d" % n)
            g = replace_element(g, 0x0020, 0x0013, b"%d" % (n + 1))
            with open(os.path.join(out, "s%05d.dcm" % n), "wb") as o:
                o.write(g)
            n += 1
    return n


def timed(cmd):
    p = subprocess.run(["/usr/bin/time", "-f", "TIME %e %M"] + cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(" ".join(cmd) + " failed:\n" + p.stderr)
    m = re.search(r"TIME ([0-9.]+) ([0-9]+)", p.stderr)
    return float(m.group(1)), int(m.group(2)) / 1024.0, p.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--copies", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    exe = os.path.join(a.build, "app", "isoforge")
    with tempfile.TemporaryDirectory(prefix="isoforge-dicom-") as tmp:
        series = os.path.join(tmp, "series")
        os.mkdir(series)
        slices = make_series(series, a.copies)
        size = sum(os.path.getsize(os.path.join(series, f)) for f in os.listdir(series))
        print(f"series: {slices} slices of 512 x 512 ({size / 2**20:.0f} MiB of files, "
              f"{slices * 512 * 512 * 4 / 2**20:.0f} MiB as floats)\n")
        whole, streamed = "read whole (--read-whole)", "streamed (the default)"
        rows = {whole: [], streamed: []}
        for _ in range(a.repeat):  # alternating
            rows[whole].append(
                timed([exe, "mesh", series, "--iso", "300", "-o", os.path.join(tmp, "whole.ply"), "--read-whole"]))
            rows[streamed].append(timed([exe, "mesh", series, "--iso", "300", "-o", os.path.join(tmp, "streamed.ply")]))
            if "pass" not in rows[streamed][-1][2]:
                raise RuntimeError("the default did not stream:\n" + rows[streamed][-1][2])
        same = filecmp.cmp(os.path.join(tmp, "whole.ply"), os.path.join(tmp, "streamed.ply"), shallow=False)
        print("| path | wall s (each run) | peak MiB |")
        print("|---|---|---:|")
        for name, runs in rows.items():
            print(f"| {name} | {' / '.join(f'{r[0]:.2f}' for r in runs)} | {max(r[1] for r in runs):.0f} |")
        tris = re.search(r"([0-9,]+) triangles", rows[whole][-1][2])
        print(f"\n{tris.group(1) if tris else '?'} triangles; the two PLY files are "
              f"{'the same bytes' if same else 'DIFFERENT'}")
        return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
