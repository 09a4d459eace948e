# Warnings and sanitizers as INTERFACE targets, linked by every target of the project.
add_library(isoforge_warnings INTERFACE)
add_library(isoforge::warnings ALIAS isoforge_warnings)
target_compile_options(isoforge_warnings INTERFACE -Wall -Wextra -Wshadow -Wno-unused-parameter
                                                   $<$<BOOL:${ISOFORGE_WERROR}>:-Werror>)
# GCC 12 warns falsely about std::string concatenation in libstdc++'s own headers (GCC bug 105651).
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
  target_compile_options(isoforge_warnings INTERFACE -Wno-restrict)
endif()

add_library(isoforge_sanitize INTERFACE)
add_library(isoforge::sanitize ALIAS isoforge_sanitize)
if(ISOFORGE_SANITIZE)
  target_compile_options(isoforge_sanitize INTERFACE -fsanitize=address,undefined -fno-omit-frame-pointer
                                                     -fno-sanitize-recover=undefined)
  target_link_options(isoforge_sanitize INTERFACE -fsanitize=address,undefined)
endif()

# Common settings for a target of ours.
function(isoforge_target target)
  target_link_libraries(${target} PRIVATE isoforge::warnings isoforge::sanitize)
endfunction()
