// isoforge-dicom-reader: reads one DICOM series with GDCM for isoforge (volume/read_dicom.cpp runs it, in
// lib/isoforge/), so that GDCM's assertions end this process and not isoforge. Not for direct use.
#include <malloc.h>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>

#include "core/isolate.h"
#include "volume/readers.h"

int main(int argc, char** argv) {
    // Slices come and go in buffers of the same sizes: keep freed memory for the next slice instead of
    // returning it to the kernel and faulting it in again (half the helper's time on a CT series).
    ::mallopt(M_MMAP_THRESHOLD, 256 << 20);
    ::mallopt(M_TRIM_THRESHOLD, 512 << 20);
    const std::string mode = argc == 5 ? argv[4] : "";
    if ((argc != 4 && argc != 5) || (argc == 5 && mode != "header" && mode != "stream")) {
        std::cerr << "usage: isoforge-dicom-reader DIRECTORY SERIES-UID MEMORY-BYTES [header|stream] (isoforge runs "
                     "this)\n";
        return 2;
    }
    if (!mode.empty())  // the description, then (stream) one slice at a time
        isoforge::helperStreamMain(
            argv[1], "GDCM", std::strtoull(argv[3], nullptr, 10), [&](const isoforge::HelperSend& send) {
                isoforge::volume::detail::streamDicomSeriesHere(argv[1], argv[2], mode == "header", send);
            });
    isoforge::helperMain(argv[1], "GDCM", std::strtoull(argv[3], nullptr, 10), [&] {
        // The voxels are written from the volume itself, then its description (volume/readers.h).
        namespace detail = isoforge::volume::detail;
        auto v = std::make_shared<const isoforge::volume::DenseVolume>(detail::readDicomSeriesHere(argv[1], argv[2]));
        isoforge::HelperAnswer a(detail::describeVolume(*v));
        a.first.emplace_back(reinterpret_cast<const char*>(v->values.data()), v->values.size() * sizeof(float));
        a.keep = std::move(v);
        return a;
    });
}
