# Finds every dependency of the project, with the fixes that Debian 12's packages need
# (see docs/building.md). Each module links only what it uses.

find_package(Threads REQUIRED)
find_package(TBB REQUIRED CONFIG)                     # TBB::tbb

# Debian installs FindOpenVDB.cmake outside CMake's default search path.
list(APPEND CMAKE_MODULE_PATH /usr/lib/x86_64-linux-gnu/cmake/OpenVDB /usr/lib/cmake/OpenVDB)
find_package(OpenVDB REQUIRED)                        # OpenVDB::openvdb (needs Boost iostreams)

find_package(embree 3 REQUIRED CONFIG)                # embree
find_package(OpenImageIO REQUIRED CONFIG)             # OpenImageIO::OpenImageIO
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

if(ISOFORGE_BUILD_TESTS)
  find_package(GTest REQUIRED)                        # GTest::gtest_main
endif()
