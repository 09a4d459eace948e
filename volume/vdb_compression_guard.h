#pragma once
/// @file A guard in front of OpenVDB 10's chunk readers (Debian 12 ships 10.0.1).
///
/// `openvdb::io::bloscFromStream` and `unzipFromStream` read a voxel buffer that the file says is stored
/// uncompressed (a negative chunk size) straight into the caller's buffer, and compare its size with the
/// buffer's only after reading: a file claiming a larger chunk writes its bytes past the end of a heap
/// buffer (fuzz_vdb found it; OpenVDB fixed it upstream in f02e7e1, 2023, "Fix for potential crash when
/// reading invalid .vdb files", released in 11.0). isoforge defines both functions itself: libopenvdb calls
/// them through its PLT, so these come first; each reads the chunk size, refuses an uncompressed one of the
/// wrong size, and a compressed one larger than compression could make (which OpenVDB would allocate
/// before reading), with OpenVDB's RuntimeError (an IoError naming the file, from readVdb), steps back and
/// hands the stream to OpenVDB's own function (dlsym RTLD_NEXT).

namespace isoforge::volume::detail {

/// True once OpenVDB's two functions resolve to the guarded ones in this process (tested). Calling it also
/// links the guard into every program that reads .vdb files (it lives in a static library).
bool openVdbChunkReadersGuarded();

}  // namespace isoforge::volume::detail
