#!/usr/bin/env python3
"""Writes the small whole-file seeds of the fuzz targets that real files are too big to seed whole:
two slices of a tiny DICOM CT series (for fuzz_dicom: a 2-byte length, the first file, the second),
raw volumes with their options (fuzz_raw: 3 x uint32 dims, type, flags, uint16 offset, the voxels) and
colour tables of each text kind (fuzz_label_table: a kind byte, the table).
Usage: fuzz_seeds.py dicom|raw|label_table DIR   (scripts/fuzz.sh calls it)"""
import struct
import sys
from pathlib import Path


def element(group, elem, vr, value):
    if isinstance(value, str):
        pad = b"\0" if vr == "UI" else b" "
        value = value.encode()
        if len(value) % 2:
            value += pad
    head = struct.pack("<HH", group, elem) + vr.encode()
    if vr in ("OB", "OW", "OF", "SQ", "UT", "UN"):
        return head + b"\0\0" + struct.pack("<I", len(value)) + value
    return head + struct.pack("<H", len(value)) + value


def us(v):
    return struct.pack("<H", v)


def dicom_slice(z, instance, rows=4, cols=3):
    """A Part-10 CT slice in explicit VR little endian: the tags readDicomSeries reads, int16 pixels."""
    sop_class, sop = "1.2.840.10008.5.1.4.1.1.2", "1.2.826.0.1.3680043.2.1143.7.%d" % instance
    meta = (element(2, 1, "OB", b"\0\1") + element(2, 2, "UI", sop_class) + element(2, 3, "UI", sop) +
            element(2, 0x10, "UI", "1.2.840.10008.1.2.1") + element(2, 0x12, "UI", "1.2.826.0.1.3680043.2.1143"))
    pixels = b"".join(struct.pack("<h", (i * 37 + instance * 11) % 200 - 50) for i in range(rows * cols))
    body = b"".join([
        element(8, 0x16, "UI", sop_class), element(8, 0x18, "UI", sop), element(8, 0x60, "CS", "CT"),
        element(0x20, 0xD, "UI", "1.2.826.0.1.3680043.2.1143.1"),
        element(0x20, 0xE, "UI", "1.2.826.0.1.3680043.2.1143.2"),
        element(0x20, 0x13, "IS", str(instance)), element(0x20, 0x32, "DS", "-1.5\\2\\%g" % z),
        element(0x20, 0x37, "DS", "1\\0\\0\\0\\1\\0"), element(0x20, 0x52, "UI", "1.2.826.0.1.3680043.2.1143.3"),
        element(0x28, 2, "US", us(1)),
        element(0x28, 4, "CS", "MONOCHROME2"), element(0x28, 0x10, "US", us(rows)), element(0x28, 0x11, "US", us(cols)),
        element(0x28, 0x30, "DS", "0.5\\0.75"), element(0x28, 0x100, "US", us(16)), element(0x28, 0x101, "US", us(16)),
        element(0x28, 0x102, "US", us(15)), element(0x28, 0x103, "US", us(1)), element(0x28, 0x1052, "DS", "-1024"),
        element(0x28, 0x1053, "DS", "1"), element(0x7FE0, 0x10, "OW", pixels)])
    return b"\0" * 128 + b"DICM" + element(2, 0, "UL", struct.pack("<I", len(meta))) + meta + body


def dicom_seeds(dicom):
    a, b = dicom_slice(0.0, 1), dicom_slice(2.5, 2)
    (dicom / "two-slices").write_bytes(struct.pack("<H", len(a)) + a + b)
    (dicom / "one-slice").write_bytes(struct.pack("<H", len(a)) + a)


def raw_seeds(raw):

    def raw_seed(name, dims, type_index, flags, offset, voxels):
        (raw / name).write_bytes(struct.pack("<3IBBH", *dims, type_index, flags, offset) + voxels)
    raw_seed("uint8", (4, 3, 2), 0, 0, 0, bytes(range(24)))
    raw_seed("int16-big-endian", (3, 2, 2), 3, 1, 4, b"head" + b"".join(struct.pack(">h", v * 300 - 900) for v in range(12)))
    raw_seed("float32", (2, 2, 2), 6, 2, 0, b"".join(struct.pack("<f", v / 3) for v in range(8)))
    raw_seed("hostile-dims", (100000, 100000, 100000), 0, 0, 0, bytes(84))


def label_table_seeds(table):

    (table / "itksnap.txt").write_bytes(b"\1# ITK-SNAP Label Description File\n0 0 0 0 0 0 0 \"Clear Label\"\n"
                                        b"1 255 0 0 1 1 1 \"Bone\"\n2 0 255 0 0.5 1 1 \"Skin\"\n")
    (table / "slicer.txt").write_bytes(b"\1# Slicer colour table\n0 background 0 0 0 0\n1 liver 221 130 101 255\n"
                                       b"2 kidney 185 102 83 255\n")
    (table / "names.txt").write_bytes(b"\x011 Precentral_L 2001\n2 Precentral_R 2002\n")


if __name__ == "__main__":
    kind, folder = sys.argv[1], Path(sys.argv[2])
    folder.mkdir(parents=True, exist_ok=True)
    {"dicom": dicom_seeds, "raw": raw_seeds, "label_table": label_table_seeds}[kind](folder)
