#pragma once
/// @file The page `isoforge view` serves: view/page/index.html and view/page/viewer.js, compiled in
/// (view/CMakeLists.txt writes page_files.cpp from them) so that the executable serves them from anywhere.

#include <string_view>

namespace isoforge::view {

extern const std::string_view kIndexHtml;
extern const std::string_view kViewerJs;

}  // namespace isoforge::view
