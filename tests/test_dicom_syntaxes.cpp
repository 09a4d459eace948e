// A real CT slice written again by GDCM in the transfer syntaxes scanners and PACS send (explicit VR little
// and big endian, RLE and JPEG lossless: encapsulated pixel data in fragments), read back by isoforge: the
// layout check in front of GDCM (volume/dicom_layout.cpp) must accept every one of them, and the voxels
// must be the original's. A fragment claiming more than the file holds is then refused with its offset.
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <gdcmImageChangeTransferSyntax.h>
#include <gdcmImageReader.h>
#include <gdcmImageWriter.h>
#include <gdcmTransferSyntax.h>
#include <gtest/gtest.h>

#include "core/error.h"
#include "test_util.h"
#include "volume/dense_volume.h"

using namespace isoforge;

TEST(Volumes, DicomInEveryCommonTransferSyntaxPassesTheLayoutCheck) {
    const std::filesystem::path slice = test::sharedData() / "volumes/ct-abdomen-dicom/series/1-057.dcm";
    const auto dir = test::scratchDir("dicom-syntaxes");
    std::filesystem::create_directories(dir / "original");
    std::filesystem::copy_file(slice, dir / "original/1-057.dcm", std::filesystem::copy_options::overwrite_existing);
    const volume::DenseVolume original = volume::readVolume(dir / "original");
    for (const auto& [name, syntax] : std::vector<std::pair<std::string, gdcm::TransferSyntax::TSType>>{
             {"explicit-little", gdcm::TransferSyntax::ExplicitVRLittleEndian},
             {"explicit-big", gdcm::TransferSyntax::ExplicitVRBigEndian},
             {"rle", gdcm::TransferSyntax::RLELossless},
             {"jpeg-lossless", gdcm::TransferSyntax::JPEGLosslessProcess14_1}}) {
        SCOPED_TRACE(name);
        gdcm::ImageReader reader;
        reader.SetFileName(slice.c_str());
        ASSERT_TRUE(reader.Read());
        gdcm::ImageChangeTransferSyntax change;
        change.SetTransferSyntax(syntax);
        change.SetInput(reader.GetImage());
        ASSERT_TRUE(change.Change());
        const auto out = dir / name;
        std::filesystem::create_directories(out);
        gdcm::ImageWriter writer;
        writer.SetFileName((out / "slice.dcm").c_str());
        writer.SetFile(reader.GetFile());
        writer.SetImage(change.GetOutput());
        ASSERT_TRUE(writer.Write());
        const volume::DenseVolume v = volume::readVolume(out);
        EXPECT_EQ(v.dims, original.dims);
        EXPECT_EQ(v.values, original.values);
        if (name != "rle") continue;
        // The walk reaches the fragments: the first one claiming 2 GB is refused with its offset.
        std::string bytes(std::filesystem::file_size(out / "slice.dcm"), '\0');
        std::ifstream(out / "slice.dcm", std::ios::binary).read(bytes.data(), std::streamsize(bytes.size()));
        const std::size_t pixels = bytes.rfind(std::string("\xe0\x7f\x10\x00OB\0\0\xff\xff\xff\xff", 12));
        ASSERT_NE(pixels, std::string::npos);
        const std::size_t table = pixels + 12;  // the basic offset table, an item
        ASSERT_EQ(bytes.substr(table, 4), std::string("\xfe\xff\x00\xe0", 4));
        std::uint32_t tableLength = 0;
        std::memcpy(&tableLength, bytes.data() + table + 4, 4);
        const std::size_t fragment = table + 8 + tableLength;
        bytes.replace(fragment + 4, 4, std::string("\xf0\xff\xff\x7f", 4));
        std::ofstream(out / "slice.dcm", std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
        try {
            volume::readVolume(out);
            ADD_FAILURE() << "no error";
        } catch (const IoError& e) {
            EXPECT_NE(std::string(e.what()).find("DICOM element (FFFE,E000) at byte " + std::to_string(fragment) +
                                                 " (an item) claims 2147483632 bytes"),
                      std::string::npos)
                << e.what();
        }
    }
}
