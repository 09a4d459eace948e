// Volume files read a run of slices at a time (volume/voxel_source.h): every streamable format gives
// readVolume's voxels and range, and cut and corrupt data is an error.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>

#include <zlib.h>

#include "core/error.h"
#include "test_util.h"
#include "volume/dense_grid.h"
#include "volume/near_level.h"
#include "volume/voxel_source.h"

using namespace isoforge;
namespace fs = std::filesystem;

namespace {

void writeFile(const fs::path& p, const std::string& bytes) {
    std::ofstream(p, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}

std::string readFile(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string gzipped(const std::string& bytes) {
    z_stream z{};
    deflateInit2(&z, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);  // a gzip wrapper
    std::string out(deflateBound(&z, uLong(bytes.size())) + 32, '\0');
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
    z.avail_in = uInt(bytes.size());
    z.next_out = reinterpret_cast<Bytef*>(out.data());
    z.avail_out = uInt(out.size());
    deflate(&z, Z_FINISH);
    out.resize(z.total_out);
    deflateEnd(&z);
    return out;
}

/// Streams every slice of `path` in runs of `run` slices, and checks them, the header and the range
/// against readVolume's.
void expectReadVolumesVoxels(const fs::path& path, const volume::VolumeReadOptions& o = {}) {
    SCOPED_TRACE(path.string());
    const volume::DenseVolume whole = volume::readVolume(path, o);
    const std::optional<volume::VoxelSource> source = volume::voxelSource(path, o);
    ASSERT_TRUE(source);
    const volume::DenseVolume& h = source->header;
    EXPECT_EQ(h.dims, whole.dims);
    EXPECT_EQ(h.format, whole.format);
    EXPECT_EQ(h.storedType, whole.storedType);
    EXPECT_EQ(h.notes, whole.notes);
    EXPECT_TRUE(h.indexToWorld == whole.indexToWorld);
    for (std::int64_t run : {std::int64_t{1}, std::int64_t{7}, whole.dims[2]}) {
        volume::SliceStream stream(*source);
        std::vector<float> all;
        std::vector<float> buffer;
        for (std::int64_t z = 0; z < whole.dims[2]; z += run) {
            const std::int64_t n = std::min(run, whole.dims[2] - z);
            buffer.resize(std::size_t(whole.dims[0] * whole.dims[1] * n));
            stream.read(n, buffer.data());
            all.insert(all.end(), buffer.begin(), buffer.end());
        }
        ASSERT_EQ(all.size(), whole.values.size());
        EXPECT_EQ(std::memcmp(all.data(), whole.values.data(), all.size() * sizeof(float)), 0) << "run " << run;
    }
    // The range found as the slices stream past, as the slab path takes it.
    EXPECT_EQ(volume::nearLevelGrid(*source, {}).range, whole.range());
}

}  // namespace

TEST(VoxelSource, EveryStreamableFormatGivesReadVolumesVoxels) {
    const fs::path v = test::sharedData() / "volumes";
    expectReadVolumesVoxels(v / "flair-oblique-nrrd/FLAIR.nrrd");      // NRRD, attached, gzip
    expectReadVolumesVoxels(v / "headsq-ct-nrrd/quarter.nhdr");        // NRRD, 93 data files, raw
    expectReadVolumesVoxels(v / "colin27-mri-atlases/ch2.nii.gz");     // NIfTI-1, gzip
    expectReadVolumesVoxels(v / "frog-tissue-labels/frogtissue.mhd");  // MetaImage, zlib data file
    expectReadVolumesVoxels(v / "head-mr-small/HeadMRVolume.mhd");     // MetaImage, raw data file
    expectReadVolumesVoxels(v / "ct-abdomen-dicom/series");            // DICOM: slices from the helper

    // What the bundled files do not show: a float NIfTI uncompressed, big-endian raw voxels after a
    // header, NRRD's byte skips (-1: the voxels end the file; on gzip data: decoded bytes), line skips.
    const fs::path dir = test::scratchDir("voxel-source");
    volume::DenseVolume ch2 = volume::readVolume(v / "colin27-mri-atlases/ch2.nii.gz");
    for (float& x : ch2.values) x = x * 0.37f - 12.f;
    volume::writeNifti(dir / "ch2.nii", ch2);
    expectReadVolumesVoxels(dir / "ch2.nii");

    std::string big;  // 37 x 23 x 19 int16, big-endian, after 100 bytes of someone's header
    for (int k = 0; k < 19; ++k)
        for (int j = 0; j < 23; ++j)
            for (int i = 0; i < 37; ++i) {
                const auto s = std::int16_t(i * 31 - j * j + k * 700 - 4000);
                big += char((std::uint16_t(s) >> 8) & 0xff);
                big += char(s & 0xff);
            }
    writeFile(dir / "vox.raw", std::string(100, 'h') + big);
    volume::VolumeReadOptions raw;
    raw.rawDims = {37, 23, 19};
    raw.rawType = "int16";
    raw.rawBigEndian = true;
    raw.rawOffset = 100;
    raw.rawSpacing = {0.5, 0.7, 2.0};
    expectReadVolumesVoxels(dir / "vox.raw", raw);

    writeFile(dir / "tail.bin", "two lines\nof junk\n" + std::string(55, 'x') + big);
    writeFile(dir / "tail.nhdr",
              "NRRD0004\ntype: short\ndimension: 3\nsizes: 37 23 19\nspacings: 1 2 3\nendian: big\n"
              "encoding: raw\nbyte skip: -1\ndata file: tail.bin\n");
    expectReadVolumesVoxels(dir / "tail.nhdr");
    writeFile(dir / "skips.nrrd",
              "NRRD0004\r\ntype: short\r\ndimension: 3\r\nsizes: 37 23 19\r\nendian: big\r\nencoding: gzip\r\n"
              "byte skip: 6\r\n\r\n" +
                  gzipped("junk!!" + big));
    expectReadVolumesVoxels(dir / "skips.nrrd");
    writeFile(dir / "lines.bin", "# a line\n# another\n" + big);
    writeFile(dir / "lines.nhdr",
              "NRRD0004\ntype: short\ndimension: 3\nsizes: 37 23 19\nendian: big\nencoding: raw\nline skip: 2\n"
              "data file: lines.bin\n");
    expectReadVolumesVoxels(dir / "lines.nhdr");
    fs::remove_all(dir);
}

TEST(VoxelSource, CutAndCorruptDataIsAnErrorNamingTheFile) {
    const fs::path v = test::sharedData() / "volumes";
    const fs::path dir = test::scratchDir("voxel-source-bad");
    const std::string flair = readFile(v / "flair-oblique-nrrd/FLAIR.nrrd");
    const std::size_t header = flair.find("\n\n") + 2;
    const auto expectError = [&](const fs::path& p, const std::string& words) {
        SCOPED_TRACE(p.string());
        std::optional<volume::VoxelSource> s;
        try {
            s = volume::voxelSource(p);
            ASSERT_TRUE(s);
            volume::nearLevelGrid(*s, {});
            ADD_FAILURE() << "no error";
        } catch (const IoError& e) {
            EXPECT_NE(std::string(e.what()).find(p.filename().string()), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
        }
    };
    writeFile(dir / "cut.nrrd", flair.substr(0, header + (flair.size() - header) * 3 / 5));
    expectError(dir / "cut.nrrd", "ends");
    std::string zeros = flair;
    std::fill(zeros.begin() + std::ptrdiff_t(header), zeros.begin() + std::ptrdiff_t(header + 64), '\0');
    writeFile(dir / "zeros.nrrd", zeros);
    expectError(dir / "zeros.nrrd", "corrupt");
    // A raw data file shorter than its header says: refused before any voxel is read.
    const std::string mhd = readFile(v / "head-mr-small/HeadMRVolume.mhd");
    writeFile(dir / "short.mhd", mhd);
    writeFile(dir / "HeadMRVolume.raw", readFile(v / "head-mr-small/HeadMRVolume.raw").substr(0, 1000));
    EXPECT_THROW(volume::voxelSource(dir / "short.mhd"), IoError);
    fs::remove_all(dir);
}

// teem passes a "data file:" template to sprintf as it is: a file's "%s", "%n" or wide field would read or
// write through stray arguments (fuzz_volume_readers found it). Such a template is the file's error, at its
// line and column, both read whole and streamed; a template of one %d (with "%%") still reads its files.
TEST(VoxelSource, ANrrdDataFileTemplateIsNeverAFormatString) {
    const fs::path dir = test::scratchDir("voxel-source-template");
    const std::string head = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 3 2\nencoding: raw\n";
    for (const char* bad : {"x%d%n", "%d%s", "%999999999d", "a%d.%d", "%16d", "%d%-5d", "q%%%d%x"}) {
        SCOPED_TRACE(bad);
        writeFile(dir / "bad.nhdr", head + "data file: " + std::string(bad) + " 1 2 1\n");
        writeFile(dir / "bad.nrrd", head + "data file: " + std::string(bad) + " 1 2 1\r\n\r\n");
        for (const char* name : {"bad.nhdr", "bad.nrrd"}) {
            try {
                volume::readVolume(dir / name);
                ADD_FAILURE() << "read";
            } catch (const IoError& e) {
                EXPECT_NE(std::string(e.what()).find(std::string(name) + ":6:"), std::string::npos) << e.what();
                EXPECT_NE(std::string(e.what()).find("one %d"), std::string::npos) << e.what();
            }
            EXPECT_THROW(volume::voxelSource(dir / name), IoError);
        }
    }
    writeFile(dir / "q%.01.bin", "abcdef");
    writeFile(dir / "q%.02.bin", "ghijkl");
    writeFile(dir / "good.nhdr", head + "data file: q%%.%02d.bin 1 2 1\n");
    const volume::DenseVolume v = volume::readVolume(dir / "good.nhdr");
    ASSERT_EQ(v.values.size(), 12u);
    EXPECT_EQ(v.values[0], float('a'));
    EXPECT_EQ(v.values[11], float('l'));
    expectReadVolumesVoxels(dir / "good.nhdr");
    fs::remove_all(dir);
}
