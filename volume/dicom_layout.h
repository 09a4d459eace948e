#pragma once
/// @file The layout of a DICOM file (PS3.10 file meta, PS3.5 data elements), checked before GDCM reads it.
#include <filesystem>

namespace isoforge::volume::detail {

/// Walks the data elements of a Part 10 file ("DICM" at byte 128): the file meta group (as far as its
/// group length says, where that is further), then the data set in its transfer syntax (explicit or
/// implicit VR, little or big endian), into sequences, items and encapsulated pixel data. Every element's
/// header and value must lie within the file and within the item or sequence that holds it.
///
/// Why: GDCM asserts on a meta element cut by the end of the file (Debian builds it with assertions, which
/// end the process), and allocates and clears a claimed value length before it reads the value (a 4 KB
/// file made it clear 1.3 GB). Files without the "DICM" prefix, deflated data sets, and what this walk
/// does not understand (no explicit VR where one belongs, an undefined length on a plain element, nesting
/// past 64) are left to GDCM, which runs in a helper program with bounded memory anyway.
/// @throw IoError naming the file, the element and its byte offset.
void checkDicomLayout(const std::filesystem::path& file);

}  // namespace isoforge::volume::detail
