// isoforge-dicom-reader: reads one DICOM series with GDCM for isoforge (volume/read_dicom.cpp runs it, in
// lib/isoforge/), so that GDCM's assertions end this process and not isoforge. Not for direct use.
#include <cstdlib>
#include <iostream>

#include "core/isolate.h"
#include "volume/readers.h"

int main(int argc, char** argv) {
    if (argc != 4) {
        std::cerr << "usage: isoforge-dicom-reader DIRECTORY SERIES-UID MEMORY-BYTES (isoforge runs this)\n";
        return 2;
    }
    isoforge::helperMain(argv[1], "GDCM", std::strtoull(argv[3], nullptr, 10), [&] {
        return isoforge::volume::detail::serializeVolume(
            isoforge::volume::detail::readDicomSeriesHere(argv[1], argv[2]));
    });
}
