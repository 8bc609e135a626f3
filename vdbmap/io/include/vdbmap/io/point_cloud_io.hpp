// Point clouds: PLY (ascii, binary little/big endian), PCD (ascii, binary, binary_compressed)
// and raw little-endian float32 xyz (.bin), chosen by the file's extension.
#pragma once

#include "vdbmap/types.hpp"

#include <filesystem>

namespace vdbmap::io {

/// Reads the x, y, z of every point (other fields are skipped; NaN points are kept, they mark
/// invalid returns). A PCD's VIEWPOINT is ignored: points are returned as stored. Throws
/// std::runtime_error naming the file and line (or point) on missing, malformed or truncated input.
PointCloud readPointCloud(const std::filesystem::path& path);

/// Writes by extension: .ply (binary little endian, float x y z), .pcd (binary, float x y z) or
/// .bin (float32 xyz, little endian, no header). Atomic: temporary file then rename.
void writePointCloud(const std::filesystem::path& path, const PointCloud& points);

}  // namespace vdbmap::io
