"""The Python package on real inputs: the same meshes as the command line, closed and oriented, numpy
conventions, errors as exceptions, the GIL released during long calls."""

import pathlib
import threading
import time

import numpy as np
import pytest

import isoforge as iso

from conftest import read_png


def valid(mesh):
    r = mesh.check()
    assert r["valid_closed_surface"], r
    return r


# --- the same bytes as the command line -------------------------------------------------------------------


@pytest.mark.parametrize(
    "make, args",
    [
        (lambda: iso.shape("torus(R=1, r=0.3)").mesh(voxel=0.03), ["--shape", "torus(R=1, r=0.3)", "--voxel", "0.03"]),
        (lambda: iso.Scene.load("tests/data/openscad/hexnut.csg").mesh(resolution=48, sharp=True, max_error=0.02),
         ["tests/data/openscad/hexnut.csg", "--resolution", "48", "--sharp", "--max-error", "0.02"]),
        (lambda: iso.Scene.load("tests/data/openscad/hexnut.csg").mesh(resolution=48, sharp=True, normals=True),
         ["tests/data/openscad/hexnut.csg", "--resolution", "48", "--sharp", "--normals"]),
        (lambda: iso.Scene.load("examples/bracket.isf").mesh(resolution=80),
         ["examples/bracket.isf", "--resolution", "80"]),
        (lambda: iso.Grid.load("data/sphere.vdb").mesh(), ["data/sphere.vdb"]),
        (lambda: iso.vm("data/text.vm").mesh(resolution=64), ["data/text.vm", "--resolution", "64"]),
    ],
    ids=["shape", "csg-sharp-simplified", "csg-sharp-crease-normals", "isf-colours", "vdb", "vm"],
)
def test_meshes_are_the_command_lines_bytes(make, args, cli, root, tmp_path, monkeypatch):
    monkeypatch.chdir(root)
    mine, theirs = tmp_path / "py.ply", tmp_path / "cli.ply"
    make().save(str(mine))
    cli("mesh", *args, "-o", theirs)
    assert mine.read_bytes() == theirs.read_bytes()


def test_a_ct_volume_meshes_as_the_command_line_does(cli, root, tmp_path):
    vol, affine = iso.read_volume(str(root / "data/headsq/quarter.nhdr"))
    mine, theirs = tmp_path / "py.ply", tmp_path / "cli.ply"
    iso.Grid.from_numpy(vol, affine=affine).mesh(iso=1150).save(str(mine))
    cli("mesh", root / "data/headsq/quarter.nhdr", "--iso", "1150", "-o", theirs)
    assert mine.read_bytes() == theirs.read_bytes()


# --- fields and CSG ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("voxel", [0.08, 0.04, 0.02])
def test_the_issue_example_is_closed_oriented_and_free_of_self_intersections(voxel):
    f = (iso.box(2) - iso.cylinder(r=0.4, h=3)) | iso.sphere(0.8).translate((0, 0, 1))
    f = iso.smooth_union(f, iso.torus(1, 0.2), k=0.1)
    m = f.mesh(voxel=voxel)
    r = m.check(self_intersections=True)
    assert r["valid_closed_surface"] and r["self_intersecting_pairs"] == 0


def test_operators_are_the_booleans():
    a, b = iso.sphere(1), iso.sphere(1).translate((1, 0, 0))
    p = np.array([[-0.9, 0, 0], [0.5, 0, 0], [1.9, 0, 0], [3, 0, 0]], np.float32)
    inside = lambda f: (f(p) < 0).tolist()  # noqa: E731
    assert inside(a | b) == [True, True, True, False]
    assert inside(a & b) == [False, True, False, False]
    assert inside(a - b) == [True, False, False, False]
    np.testing.assert_allclose(iso.sphere(2)(p), np.linalg.norm(p, axis=1) - 2, atol=1e-6)


def test_sharp_meshes_with_normals_split_their_creases_and_stay_closed_by_position():
    box = iso.box((2, 1, 0.5)).rotate(30, (1, 1, 0))
    split = box.mesh(voxel=0.05, sharp=True, normals=True)
    one = box.mesh(voxel=0.05, sharp=True, normals=True, crease_angle=180)
    r = valid(split)
    assert r["welded_vertices"] > 0 and len(split.vertices) == len(one.vertices) + r["welded_vertices"]
    assert valid(one)["welded_vertices"] == 0
    np.testing.assert_array_equal(split.triangles.shape, one.triangles.shape)
    with pytest.raises(ValueError):
        box.mesh(voxel=0.05, sharp=True, normals=True, crease_angle=200)


def test_volumes_and_areas_converge_to_the_analytic_ones():
    for voxel in (0.05, 0.025):
        r = valid(iso.sphere(1).mesh(voxel=voxel))
        assert abs(r["volume"] - 4 / 3 * np.pi) / (4 / 3 * np.pi) < 0.01
    r = valid(iso.torus(1, 0.25).mesh(voxel=0.02))
    assert r["genus"] == 1
    r = valid(iso.box((2, 1, 0.5)).rotate(30, (1, 1, 0)).mesh(voxel=0.02, sharp=True))
    assert abs(r["volume"] - 1.0) < 0.01


def test_grids_give_dense_arrays_of_any_box(tmp_path):
    grid = iso.sphere(1).sample(voxel=0.1)
    whole = grid.to_numpy()
    assert whole.shape == tuple(hi - lo + 1 for lo, hi in zip(*grid.index_bounds))
    part = grid.to_numpy(((-0.25, -0.25, -0.25), (0.25, 0.25, 0.25)))  # voxel centres at -0.2 .. 0.2
    assert part.shape == (5, 5, 5) and part[2, 2, 2] == pytest.approx(-0.3)  # inside: the band's -3 voxels
    grid.save(str(tmp_path / "s.vdb"))
    np.testing.assert_array_equal(iso.Grid.load(str(tmp_path / "s.vdb")).to_numpy(), whole)


def test_transforms_move_the_clip_box_with_the_field():
    f = iso.expr("x^2 + y^2 + z^2 - 1", box=((-1.2,) * 3, (1.2,) * 3)).translate((5, 0, 0))
    (lo, hi) = f.bounds
    assert lo[0] == pytest.approx(3.8) and hi[0] == pytest.approx(6.2)
    m = f.mesh(resolution=64)
    assert valid(m) and m.vertices[:, 0].min() > 3.9


def test_mesh_arrays_are_views_not_copies():
    m = iso.sphere(1).mesh(resolution=32)
    v1, v2 = m.vertices, m.vertices
    assert v1.dtype == np.float32 and v1.shape[1] == 3 and m.triangles.dtype == np.int32
    assert v1.__array_interface__["data"][0] == v2.__array_interface__["data"][0]
    v1[0, 0] = 42.0
    assert m.vertices[0, 0] == 42.0
    del m
    assert v1[0, 0] == 42.0  # the array keeps the mesh alive


def test_fields_save_as_fogleman_sdf_does(tmp_path):
    m = iso.sphere(1).save(str(tmp_path / "s.stl"), step=0.05)
    assert valid(iso.Mesh.load(str(tmp_path / "s.stl")))["triangles"] == len(m)


def test_meshes_round_trip_through_numpy_and_files(tmp_path):
    m = iso.torus(1, 0.3).mesh(resolution=48)
    copy = iso.Mesh(m.vertices.astype(np.float64), m.triangles.astype(np.int64))
    np.testing.assert_array_equal(copy.vertices, m.vertices)
    for ext in ("ply", "stl", "obj", "glb"):
        m.save(str(tmp_path / f"t.{ext}"))
    back = iso.Mesh.load(str(tmp_path / "t.ply"))
    np.testing.assert_array_equal(back.triangles, m.triangles)
    simple = m.simplify(0.01)
    assert len(simple) < len(m) and valid(simple)["genus"] == 1


# --- marching_cubes: scikit-image's conventions -------------------------------------------------------------


def ball(shape, centre, radius):
    idx = np.indices(shape).astype(np.float32)
    d = np.sqrt(sum((idx[a] - centre[a]) ** 2 for a in range(3)))
    return (radius - d).astype(np.float32)


def test_marching_cubes_vertices_follow_the_array_axes_and_spacing():
    vol = ball((40, 50, 60), (12, 25, 40), 8)
    spacing = (0.5, 1.0, 2.0)
    verts, faces, normals, values = iso.marching_cubes(vol, 0.0, spacing=spacing)
    assert verts.dtype == np.float32 and faces.dtype == np.int32 and normals.shape == verts.shape
    np.testing.assert_allclose(verts.mean(axis=0), np.array([12, 25, 40]) * spacing, atol=0.05)
    assert np.all(values >= 0.0)
    r = valid(iso.Mesh(verts, faces))
    assert r["volume"] == pytest.approx(4 / 3 * np.pi * 8**3 * 0.5 * 1.0 * 2.0, rel=0.02)
    # outward normals: from the centre towards the vertex
    outward = np.einsum("ij,ij->i", normals, verts - np.array([12, 25, 40]) * spacing)
    assert np.all(outward > 0)


def test_marching_cubes_values_are_the_larger_end_of_each_vertex_edge():
    # A ball far from the origin with an uneven spacing: the positions' float rounding must not move a
    # vertex onto the wrong edge. Each vertex lies on a grid edge along one axis; the level lies between
    # its two ends, and `values` is the larger.
    vol = ball((70, 90, 110), (40, 52, 71), 17.3)
    spacing = np.array([0.8, 1.3, 2.7])
    for layout in (vol, np.asfortranarray(vol)):
        verts, faces, normals, values = iso.marching_cubes(layout, 0.5, spacing=tuple(spacing))
        idx = verts.astype(np.float64) / spacing
        off = np.abs(idx - np.round(idx))
        axis = np.argmax(off, axis=1)
        assert np.all(np.sort(off, axis=1)[:, 1] < 1e-3)  # the other two axes are whole
        lo, hi = np.round(idx).astype(int), np.round(idx).astype(int)
        rows = np.arange(len(idx))
        lo[rows, axis] = np.floor(idx[rows, axis])
        hi[rows, axis] = np.ceil(idx[rows, axis])
        a, b = vol[tuple(lo.T)], vol[tuple(hi.T)]
        np.testing.assert_array_equal(values, np.maximum(a, b))
        assert np.all(np.maximum(a, b) > 0.5) and np.all(np.minimum(a, b) <= 0.5)
        # numpy's arrays, writable, alive after the call's own objects are gone
        for arr in (verts, faces, normals, values):
            assert arr.flags.writeable and arr.flags.c_contiguous
        verts[:] += 1.0
        faces[0] = faces[1]
        assert np.all(verts.mean(axis=0) > 0)


def test_marching_cubes_is_the_same_for_any_layout_and_dtype():
    vol = ball((30, 34, 38), (15, 16, 17), 10)
    a = iso.marching_cubes(vol, 0.0)
    b = iso.marching_cubes(np.asfortranarray(vol), 0.0)
    c = iso.marching_cubes(vol.astype(np.float64), 0.0)
    key = lambda v: v[np.lexsort(v.T)]  # noqa: E731
    np.testing.assert_allclose(key(a[0]), key(b[0]), atol=1e-5)
    np.testing.assert_array_equal(a[0], c[0])
    assert valid(iso.Mesh(b[0], b[1]))


def test_marching_cubes_closes_surfaces_at_the_border_and_takes_ascent():
    vol = ball((20, 20, 20), (0, 10, 10), 6)  # cut in half by the array's first face
    verts, faces, _, _ = iso.marching_cubes(vol, 0.0)
    valid(iso.Mesh(verts, faces))
    v2, f2, _, _ = iso.marching_cubes(-vol, 0.0, gradient_direction="ascent")
    np.testing.assert_allclose(v2, verts, atol=1e-5)
    assert valid(iso.Mesh(v2, f2))
    half, _, _, _ = iso.marching_cubes(vol, 0.0, step_size=2)
    assert len(half) < len(verts) / 3


def test_marching_cubes_finds_the_vertices_scikit_image_finds():
    skimage = pytest.importorskip("skimage.measure")
    vol = ball((48, 40, 44), (24, 20, 22), 13.3)
    ours = iso.marching_cubes(vol, 0.0, spacing=(1, 2, 3))[0]
    theirs = skimage.marching_cubes(vol, 0.0, spacing=(1, 2, 3))[0]
    theirs = np.unique(np.round(theirs, 4), axis=0)  # scikit-image repeats vertices
    assert len(ours) == len(theirs)
    key = lambda v: v[np.lexsort(np.round(v, 3).T)]  # noqa: E731
    np.testing.assert_allclose(key(ours), key(theirs), atol=2e-3)


def test_marching_cubes_refuses_what_it_cannot_honour():
    vol = ball((10, 10, 10), (5, 5, 5), 3)
    with pytest.raises(ValueError, match="mask"):
        iso.marching_cubes(vol, 0.0, mask=vol > 0)
    with pytest.raises(ValueError, match="outside the volume's range"):
        iso.marching_cubes(vol, 100.0)
    with pytest.raises(ValueError, match="3D"):
        iso.marching_cubes(np.zeros((4, 4)), 0.0)


# --- volumes ----------------------------------------------------------------------------------------------


def test_read_volume_gives_the_files_voxels_and_patient_coordinates(root, cli):
    vol, affine = iso.read_volume(str(root / "data/headsq/quarter.nhdr"))
    info = cli("info", root / "data/headsq/quarter.nhdr").stdout
    assert vol.flags["F_CONTIGUOUS"] and vol.dtype == np.float32
    assert " x ".join(map(str, vol.shape)) in info
    assert affine.shape == (4, 4) and np.all(affine[3] == [0, 0, 0, 1])
    ras = iso.read_volume(str(root / "data/headsq/quarter.nhdr"), space="RAS")[1]
    np.testing.assert_array_equal(ras[:2], -affine[:2])


def test_read_volume_reads_a_dicom_series(shared):
    series = shared / "volumes/ct-abdomen-dicom/series"
    if not series.is_dir():
        pytest.skip("no DICOM series in ../shared/data")
    vol, affine = iso.read_volume(str(series))
    assert vol.ndim == 3 and vol.shape[2] > 1 and vol.min() < -500  # air in Hounsfield units


# --- scenes and images ------------------------------------------------------------------------------------


def test_render_gives_the_command_lines_pixels(cli, root, tmp_path, monkeypatch):
    monkeypatch.chdir(root)
    scene = iso.Scene.load("tests/data/openscad/CSG.csg")
    for method in ("mesh", "march"):
        img = iso.render(scene, size=(160, 120), method=method, resolution=96)
        out = tmp_path / f"{method}.png"
        cli("render", "tests/data/openscad/CSG.csg", "--size", "160x120", "--method", method, "--resolution", "96",
            "-o", out)
        theirs = read_png(out)[:, :, :3]
        assert img.shape == theirs.shape and img.dtype == np.uint8
        assert np.abs(img.astype(int) - theirs.astype(int)).max() <= 1


def test_render_takes_fields_grids_and_meshes():
    for what in (iso.sphere(1), iso.sphere(1).sample(voxel=0.05), iso.sphere(1).mesh(resolution=32)):
        img = iso.render(what, size=(64, 48))
        assert img.shape == (48, 64, 3) and img.std() > 5  # something was drawn


# --- errors ------------------------------------------------------------------------------------------------


def test_bad_input_raises_with_the_command_lines_messages(tmp_path, root):
    with pytest.raises(iso.ParseError, match=r"broken\.isf:2:9"):
        iso.Scene.parse("sphere(1);\ncube(2, ;", "broken.isf")
    with pytest.raises(iso.IoError, match="nothing.ply"):
        iso.Mesh.load(str(tmp_path / "nothing.ply"))
    cut = tmp_path / "cut.vdb"
    cut.write_bytes((root / "data/sphere.vdb").read_bytes()[:3000])
    with pytest.raises(OSError, match="cut.vdb"):
        iso.Grid.load(str(cut))
    with pytest.raises(iso.ParseError, match=r"expression:1:7"):
        iso.expr("x^2 + * y")
    with pytest.raises(MemoryError, match="MiB|GiB|estimate"):
        iso.sphere(1).mesh(voxel=1e-5)
    with pytest.raises(ValueError, match="unbounded"):
        iso.plane().mesh()
    with pytest.raises(TypeError):
        iso.render("not a scene")


# --- long calls --------------------------------------------------------------------------------------------


def test_long_calls_release_the_gil_and_report_progress():
    reports = []
    ticks = 0
    done = threading.Event()

    def work():
        iso.sphere(1).mesh(voxel=0.004, progress=lambda s, d, t: reports.append((s, d, t)))
        done.set()

    t = threading.Thread(target=work)
    t.start()
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    t.join()
    assert ticks > 50, "the main thread stalled: the GIL was held"
    stages = {s for s, _, _ in reports if s}
    assert reports and reports[-1][0] is None and len(stages) >= 1


def test_ctrl_c_interrupts_a_long_call(tmp_path):
    import os
    import signal
    import subprocess
    import sys

    script = (
        "import isoforge as iso, sys\n"
        "print('started', flush=True)\n"
        "try:\n"
        "    iso.sphere(1).mesh(voxel=0.0015)\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted', flush=True); sys.exit(3)\n"
    )
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, env=dict(os.environ))
    assert p.stdout.readline().strip() == "started"
    time.sleep(0.8)
    start = time.monotonic()
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=60)
    assert p.returncode == 3 and "interrupted" in out
    assert time.monotonic() - start < 5
