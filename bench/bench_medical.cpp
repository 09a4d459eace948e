// Medical volumes, timed: (1) reading the abdominal CT (DICOM, 512 x 512 x 48) and meshing bone at 300 HU,
// stage by stage, with peak memory; (2) every label of the AAL atlas (116 labels, 181 x 217 x 181) by
// volume::labelSurfaces (one pass bucketing voxels, each label meshed in its own bounding box, labels in
// parallel) against running our single-iso core once per label on the whole volume's indicator. The
// anchor for (1) and a second one for (2) is VTK's flying edges: bench/medical_vs_vtk.sh runs
// bench/vtk_flying_edges.py on the same inputs and prints the ratios.
// Usage: bench_medical [--quick]   (prints "key value" lines the script reads, then a table)
#include <cstdio>
#include <cstring>

#include "bench_util.h"
#include "volume/dense_grid.h"
#include "volume/dense_volume.h"
#include "volume/labels.h"
#include "volume/marching_cubes.h"
#include "volume/vdb_io.h"

using namespace isoforge;

int main(int argc, char** argv) {
    bench::checkArguments(argc, argv, "Usage: bench_medical [--quick]", {"--quick"});
    volume::initializeOpenVdb();
    const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
    const std::string vols = std::string(ISOFORGE_SHARED_DATA) + "/volumes/";

    // (1) CT bone: read, sparse grid, mesh.
    bench::Samples read, convert, meshing, total;
    std::size_t triangles = 0;
    long long peak = 0;
    for (int rep = 0; rep < (quick ? 1 : 3); ++rep) {
        volume::DenseVolume v;
        openvdb::FloatGrid::Ptr grid;
        mesh::TriMesh m;
        const auto all = bench::timed([&] {
            read.seconds.push_back(
                bench::timed([&] { v = volume::readVolume(vols + "ct-abdomen-dicom/series"); }).first);
            convert.seconds.push_back(bench::timed([&] { grid = volume::toGrid(v); }).first);
            volume::MeshingOptions o;
            o.isovalue = 300.f;
            o.inside = volume::InsideSide::Above;
            meshing.seconds.push_back(bench::timed([&] { m = volume::extractIsosurface(*grid, o); }).first);
        });
        total.seconds.push_back(all.first);
        peak = std::max(peak, all.second);
        triangles = m.triangleCount();
    }
    std::printf("ct_read %.4f\nct_convert %.4f\nct_mesh %.4f\nct_total %.4f\nct_triangles %zu\nct_peak_mib %.1f\n",
                read.median(), convert.median(), meshing.median(), total.median(), triangles, double(peak) / (1 << 20));

    // (2) AAL labels: all at once vs the single-iso core once per label on the whole volume.
    const volume::DenseVolume aal = volume::readVolume(vols + "colin27-mri-atlases/aal.nii.gz");
    std::vector<volume::LabelSurface> surfaces, shared;
    const auto ours =
        bench::timed([&] { surfaces = volume::labelSurfaces(aal, nullptr, volume::LabelMethod::MarchingCubes); });
    std::size_t labelTriangles = 0, sharedTriangles = 0;
    for (const auto& s : surfaces) labelTriangles += s.mesh.triangleCount();
    const auto sharedRun =
        bench::timed([&] { shared = volume::labelSurfaces(aal, nullptr, volume::LabelMethod::Shared); });
    for (const auto& s : shared) sharedTriangles += s.mesh.triangleCount();
    std::printf("shared_seconds %.4f\nshared_triangles %zu\nshared_peak_mib %.1f\n", sharedRun.first, sharedTriangles,
                double(sharedRun.second) / (1 << 20));
    double perLabel = -1;
    long long perLabelPeak = 0;
    std::size_t perLabelTriangles = 0;
    if (!quick) {
        const auto r = bench::timed([&] {
            volume::DenseVolume indicator = aal;
            for (const auto& s : surfaces) {
                for (std::size_t i = 0; i < aal.values.size(); ++i)
                    indicator.values[i] = std::lround(aal.values[i]) == s.label ? 1.f : 0.f;
                volume::ToGridOptions to;
                to.background = 0.f;
                const auto grid = volume::toGrid(indicator, to);
                volume::MeshingOptions o;
                o.isovalue = 0.5f;
                o.inside = volume::InsideSide::Above;
                perLabelTriangles += volume::extractIsosurface(*grid, o).triangleCount();
            }
        });
        perLabel = r.first;
        perLabelPeak = r.second;
    }
    std::printf("labels_count %zu\nlabels_seconds %.4f\nlabels_triangles %zu\nlabels_peak_mib %.1f\n", surfaces.size(),
                ours.first, labelTriangles, double(ours.second) / (1 << 20));
    std::printf("per_label_seconds %.4f\nper_label_triangles %zu\nper_label_peak_mib %.1f\n", perLabel,
                perLabelTriangles, double(perLabelPeak) / (1 << 20));
    return 0;
}
