// The version of vdbmap. The single source of truth: the top-level CMakeLists.txt reads it into
// project(VERSION), and the installed package's vdbmapConfigVersion.cmake is made from that.
#pragma once

#define VDBMAP_VERSION_MAJOR 0
#define VDBMAP_VERSION_MINOR 1
#define VDBMAP_VERSION_PATCH 0
#define VDBMAP_VERSION_STRING "0.1.0"

namespace vdbmap {
/// "major.minor.patch", e.g. for --version and the Python module's __version__.
inline constexpr const char* kVersion = VDBMAP_VERSION_STRING;
}  // namespace vdbmap
