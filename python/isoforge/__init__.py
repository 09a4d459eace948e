"""isoforge: implicit surfaces, CSG scenes and volumes to closed, oriented meshes.

    import numpy as np, isoforge as iso
    verts, faces, normals, values = iso.marching_cubes(volume, level=0.5, spacing=(0.8, 0.8, 1.5))
    f = (iso.box(2) - iso.cylinder(r=0.4, h=3)) | iso.sphere(0.8).translate((0, 0, 1))
    mesh = f.mesh(voxel=0.01)          # iso.Mesh: vertices (N, 3) float32, triangles (M, 3) int32
    mesh.save("part.glb"); print(mesh.check())

Every algorithm is isoforge's C++ library (the extension module isoforge._isoforge); docs/python.md
documents the package.
"""

from ._isoforge import (  # noqa: F401
    Field,
    Grid,
    IoError,
    Mesh,
    ParseError,
    ResourceError,
    Scene,
    box,
    capsule,
    cone,
    cylinder,
    difference,
    ellipsoid,
    expr,
    intersection,
    marching_cubes,
    plane,
    read_volume,
    render,
    shape,
    smooth_difference,
    smooth_intersection,
    smooth_union,
    sphere,
    torus,
    union,
    vm,
)



def _field_save(self, path, *, step=None, **mesh_options):
    """Meshes the field and writes the mesh (fogleman/sdf's `f.save('out.stl', step=0.01)`): `step` is the
    voxel size; other keywords go to Field.mesh (voxel, resolution, sharp, max_error, ...). Returns the Mesh."""
    if step is not None:
        mesh_options["voxel"] = step
    mesh = self.mesh(**mesh_options)
    mesh.save(path)
    return mesh


Field.save = _field_save

__all__ = [
    "Field", "Grid", "IoError", "Mesh", "ParseError", "ResourceError", "Scene", "box", "capsule", "cone",
    "cylinder", "difference", "ellipsoid", "expr", "intersection", "marching_cubes", "plane", "read_volume",
    "render", "shape", "smooth_difference", "smooth_intersection", "smooth_union", "sphere", "torus", "union", "vm",
]
