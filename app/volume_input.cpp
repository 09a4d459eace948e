#include "app/volume_input.h"

#include <chrono>
#include <cstdio>
#include <sstream>

#include <openvdb/tools/Filter.h>

#include "core/number_text.h"
#include "volume/dense_grid.h"

namespace isoforge::app {

void addVolumeReadOptions(CLI::App* cmd, VolumeInput& in) {
    auto* raw = cmd->add_option_group("Raw voxels and DICOM");
    raw->add_option("--dims", in.dims, "Raw voxels: dimensions X,Y,Z")->delimiter(',')->expected(3);
    raw->add_option("--type", in.type, "Raw voxels: uint8 int8 uint16 int16 uint32 int32 float32 float64")
        ->check(CLI::IsMember({"uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64"}));
    raw->add_option("--spacing", in.spacing, "Raw voxels: spacing X,Y,Z in mm (default 1,1,1)")
        ->delimiter(',')
        ->expected(3);
    raw->add_option("--endian", in.endian, "Raw voxels: little (default) or big")
        ->check(CLI::IsMember({"little", "big"}));
    raw->add_option("--offset", in.offset, "Raw voxels: bytes to skip before the data (a header)");
    raw->add_option("--series", in.series, "DICOM: the SeriesInstanceUID (or a unique prefix) of a directory's series");
}

bool isDenseVolumeFile(const std::string& path) {
    if (path.empty() || !volume::isVolumePath(path)) return false;
    std::string e = std::filesystem::path(path).extension().string();
    for (char& c : e) c = char(std::tolower(static_cast<unsigned char>(c)));
    return e != ".vdb";
}

volume::VolumeReadOptions readOptions(const VolumeInput& in) {
    volume::VolumeReadOptions o;
    if (!in.dims.empty()) o.rawDims = {in.dims[0], in.dims[1], in.dims[2]};
    o.rawType = in.type;
    if (!in.spacing.empty()) o.rawSpacing = {in.spacing[0], in.spacing[1], in.spacing[2]};
    o.rawBigEndian = in.endian == "big";
    o.rawOffset = in.offset;
    o.dicomSeries = in.series;
    return o;
}

volume::DenseVolume loadVolume(const std::string& path, const VolumeInput& in, const GlobalOptions& g) {
    const volume::VolumeReadOptions o = readOptions(in);
    const auto t0 = std::chrono::steady_clock::now();
    volume::DenseVolume v = volume::readVolume(path, o);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!g.quiet) std::printf("%s in %.3f s\n", readSummary(path, v, v.range()).c_str(), s);
    return v;
}

std::string readSummary(const std::string& path, const volume::DenseVolume& v, std::pair<float, float> range) {
    const glm::dvec3 sp = v.spacing();
    char line[1024];
    std::snprintf(line, sizeof line, ": %lld x %lld x %lld %s voxels, spacing %g x %g x %g mm, %s, values %g .. %g",
                  (long long)v.dims[0], (long long)v.dims[1], (long long)v.dims[2], v.storedType.c_str(), sp.x, sp.y,
                  sp.z, v.orientationCode().c_str(), double(range.first), double(range.second));
    return "read " + path + " (" + v.format + (v.files > 1 ? ", " + std::to_string(v.files) + " files" : "") + ")" +
           line + (v.units.empty() ? "" : " " + v.units);
}

openvdb::FloatGrid::Ptr volumeGrid(const volume::DenseVolume& v, const VolumeInput& in, int smooth,
                                   Progress* progress) {
    volume::ToGridOptions o;
    o.tolerance = in.tolerance;
    o.progress = progress;
    openvdb::FloatGrid::Ptr grid = volume::toGrid(v, o);
    grid->setName("volume");
    if (smooth > 0) {
        // Smoothing needs the values around the active voxels: activate the background one voxel out.
        openvdb::tools::Filter<openvdb::FloatGrid> filter(*grid);
        filter.gaussian(1, smooth);
    }
    return grid;
}

openvdb::FloatGrid::Ptr volumeGridNearLevel(const volume::DenseVolume& v, float level, bool insideAbove) {
    openvdb::FloatGrid::Ptr grid =
        volume::toGridNearLevel(volume::VolumeView{v.values.data(), v.dims, v.indexToWorld, v.format}, level,
                                insideAbove, nullptr, /*exteriorOutside=*/false);
    grid->setName("volume");
    if (!v.units.empty()) grid->insertMeta("units", openvdb::StringMetadata(v.units));
    if (!v.modality.empty()) grid->insertMeta("modality", openvdb::StringMetadata(v.modality));
    return grid;
}

std::string describeVolume(const std::string& path, const volume::DenseVolume& v) {
    std::ostringstream s;
    const glm::dvec3 sp = v.spacing();
    const glm::dmat3 d = v.directions();
    const auto [lo, hi] = v.range();
    char line[512];
    s << path << ": " << v.format;
    if (v.files > 1) s << ", " << v.files << " files";
    s << "\n";
    std::snprintf(line, sizeof line, "  dimensions   %lld x %lld x %lld (%s voxels of %s)\n", (long long)v.dims[0],
                  (long long)v.dims[1], (long long)v.dims[2], countText(v.voxelCount()).c_str(), v.storedType.c_str());
    s << line;
    std::snprintf(line, sizeof line, "  spacing      %.6g x %.6g x %.6g mm\n", sp.x, sp.y, sp.z);
    s << line;
    std::snprintf(line, sizeof line,
                  "  orientation  %s (where i, j, k run: Left/Right, Posterior/Anterior, Superior/Inferior; world "
                  "coordinates are patient LPS mm)\n"
                  "  directions   i (%.4f, %.4f, %.4f)  j (%.4f, %.4f, %.4f)  k (%.4f, %.4f, %.4f)\n",
                  v.orientationCode().c_str(), d[0].x, d[0].y, d[0].z, d[1].x, d[1].y, d[1].z, d[2].x, d[2].y, d[2].z);
    s << line;
    const glm::dvec4 o = v.indexToWorld[3];
    const glm::dvec4 far =
        v.indexToWorld * glm::dvec4(double(v.dims[0] - 1), double(v.dims[1] - 1), double(v.dims[2] - 1), 1.0);
    std::snprintf(line, sizeof line, "  origin       (%.3f, %.3f, %.3f) mm; last voxel (%.3f, %.3f, %.3f) mm\n", o.x,
                  o.y, o.z, far.x, far.y, far.z);
    s << line;
    std::snprintf(line, sizeof line, "  values       %g .. %g%s\n", double(lo), double(hi),
                  v.units.empty() ? "" : (" " + v.units).c_str());
    s << line;
    if (!v.modality.empty()) s << "  modality     " << v.modality << "\n";
    for (const std::string& n : v.notes) s << "  " << n << "\n";
    return s.str();
}

}  // namespace isoforge::app
