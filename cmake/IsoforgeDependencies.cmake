# Finds every dependency of the project, with the fixes that Debian 12's packages need
# (see docs/building.md). Each module links only what it uses.

find_package(Threads REQUIRED)
find_package(TBB REQUIRED CONFIG)                     # TBB::tbb

# Debian installs FindOpenVDB.cmake outside CMake's default search path.
list(APPEND CMAKE_MODULE_PATH /usr/lib/x86_64-linux-gnu/cmake/OpenVDB /usr/lib/cmake/OpenVDB)
find_package(OpenVDB REQUIRED)                        # OpenVDB::openvdb (needs Boost iostreams)

find_package(embree 3 REQUIRED CONFIG)                # embree
find_package(OpenImageIO REQUIRED CONFIG)             # OpenImageIO::OpenImageIO
find_package(PNG REQUIRED)                            # PNG::PNG (PNG written without loading OpenImageIO)
# Debian's OpenImageIO target lists /usr/include/opencv4 even without OpenCV installed.
foreach(_prop INTERFACE_INCLUDE_DIRECTORIES INTERFACE_SYSTEM_INCLUDE_DIRECTORIES)
  get_target_property(_dirs OpenImageIO::OpenImageIO ${_prop})
  if(_dirs)
    list(FILTER _dirs EXCLUDE REGEX "opencv")
    set_target_properties(OpenImageIO::OpenImageIO PROPERTIES ${_prop} "${_dirs}")
  endif()
endforeach()

find_package(glm REQUIRED CONFIG)                     # glm::glm
find_package(CLI11 REQUIRED CONFIG)                   # CLI11::CLI11
find_package(meshoptimizer REQUIRED CONFIG)           # meshoptimizer::meshoptimizer (triangle strips)
find_package(TinyGLTF REQUIRED CONFIG)                # TinyGLTF::TinyGLTF (.glb output)
# Clipper 6.4 (Debian's libpolyclipping-dev: the version OpenSCAD 2021.01 uses) for OpenSCAD's 2D booleans
find_path(POLYCLIPPING_INCLUDE_DIR polyclipping/clipper.hpp REQUIRED)
find_library(POLYCLIPPING_LIBRARY polyclipping REQUIRED)

# Medical image formats (docs/volumes.md): niftilib (NIfTI-1/2), GDCM (DICOM), teem (NRRD), zlib (MetaImage).
# Debian 12's CMake configs of all three name files their -dev packages do not install (tools, VTK
# wrappers, static libraries), so they are found by hand.
find_package(ZLIB REQUIRED)
find_path(NIFTI_INCLUDE_DIR nifti2_io.h PATH_SUFFIXES nifti REQUIRED)
find_library(NIFTI2_LIBRARY nifti2 REQUIRED)
find_library(ZNZ_LIBRARY znz REQUIRED)
find_path(GDCM_INCLUDE_DIR gdcmImageReader.h PATH_SUFFIXES gdcm-3.0 REQUIRED)
foreach(_lib gdcmMSFF gdcmDSED gdcmDICT gdcmIOD gdcmCommon)
  find_library(${_lib}_LIBRARY ${_lib} REQUIRED)
  list(APPEND GDCM_LIBRARIES ${${_lib}_LIBRARY})
endforeach()
find_path(TEEM_INCLUDE_DIR teem/nrrd.h REQUIRED)
find_library(TEEM_LIBRARY teem PATHS /usr/lib REQUIRED)
add_library(isoforge_medical_formats INTERFACE)
add_library(isoforge::medical_formats ALIAS isoforge_medical_formats)
# nifti2_io.h includes <znzlib.h> from its own directory; teem's headers live in /usr/include/teem, which
# is included as <teem/nrrd.h> (adding /usr/include itself as a system directory breaks #include_next).
target_include_directories(isoforge_medical_formats SYSTEM INTERFACE ${NIFTI_INCLUDE_DIR})
target_compile_definitions(isoforge_medical_formats INTERFACE HAVE_ZLIB)
target_link_libraries(isoforge_medical_formats INTERFACE ${NIFTI2_LIBRARY} ${ZNZ_LIBRARY} ${TEEM_LIBRARY} ZLIB::ZLIB)
# GDCM apart: only the DICOM helper program links it (volume/CMakeLists.txt), not isoforge.
add_library(isoforge_gdcm INTERFACE)
add_library(isoforge::gdcm ALIAS isoforge_gdcm)
target_include_directories(isoforge_gdcm SYSTEM INTERFACE ${GDCM_INCLUDE_DIR})
target_link_libraries(isoforge_gdcm INTERFACE ${GDCM_LIBRARIES})

if(ISOFORGE_BUILD_TESTS)
  find_package(GTest REQUIRED)                        # GTest::gtest_main
endif()
