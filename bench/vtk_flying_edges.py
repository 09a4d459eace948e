#!/usr/bin/python3
"""VTK's flying edges on the same inputs as bench_medical: the abdominal CT (VTK's own DICOM reader) at
300 HU, and every label of the AAL atlas (vtkDiscreteFlyingEdges3D, all labels in one pass). Debian's
python3-vtk9 is a bench-only dependency. Prints "key value" lines; run by bench/medical_vs_vtk.sh."""
import resource
import sys
import time

import vtk

shared = sys.argv[1]
quick = len(sys.argv) > 2 and sys.argv[2] == "--quick"
vtk.vtkMultiThreader.SetGlobalDefaultNumberOfThreads(2)


def median(xs):
    xs = sorted(xs)
    return xs[len(xs) // 2]


reads, meshes, tris = [], [], 0
for _ in range(1 if quick else 3):
    t0 = time.perf_counter()
    reader = vtk.vtkDICOMImageReader()
    reader.SetDirectoryName(shared + "/volumes/ct-abdomen-dicom/series")
    reader.Update()
    t1 = time.perf_counter()
    # 300 HU: vtkDICOMImageReader may give stored values or rescaled ones; tell by the range.
    slope, offset = reader.GetRescaleSlope() or 1.0, reader.GetRescaleOffset()
    lo = reader.GetOutput().GetScalarRange()[0]
    iso = 300.0 if lo < 0 else (300.0 - offset) / slope
    fe = vtk.vtkFlyingEdges3D()
    fe.SetInputConnection(reader.GetOutputPort())
    fe.SetValue(0, iso)
    fe.ComputeNormalsOff()
    fe.ComputeGradientsOff()
    fe.Update()
    t2 = time.perf_counter()
    reads.append(t1 - t0)
    meshes.append(t2 - t1)
    tris = fe.GetOutput().GetNumberOfCells()
print("vtk_ct_read %.4f" % median(reads))
print("vtk_ct_mesh %.4f" % median(meshes))
print("vtk_ct_triangles %d" % tris)
print("vtk_ct_range %g..%g" % reader.GetOutput().GetScalarRange())

nii = vtk.vtkNIFTIImageReader()
nii.SetFileName(shared + "/volumes/colin27-mri-atlases/aal.nii.gz")
nii.Update()
rng = nii.GetOutput().GetScalarRange()
t0 = time.perf_counter()
dfe = vtk.vtkDiscreteFlyingEdges3D()
dfe.SetInputConnection(nii.GetOutputPort())
dfe.GenerateValues(int(rng[1]), 1, rng[1])
dfe.ComputeNormalsOff()
dfe.Update()
print("vtk_labels_seconds %.4f" % (time.perf_counter() - t0))
print("vtk_labels_triangles %d" % dfe.GetOutput().GetNumberOfCells())
print("vtk_peak_mib %.1f" % (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0))
