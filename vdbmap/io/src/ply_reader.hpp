// Private PLY reader shared by the mesh and point-cloud readers: ascii, binary little and big
// endian, every scalar type of the PLY spec. It keeps the vertex positions (x, y, z) and, when
// asked, the faces (vertex_indices or vertex_index lists) fanned into triangles; other elements
// and properties are parsed and skipped.
#pragma once

#include "vdbmap/types.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <filesystem>
#include <vector>

namespace vdbmap::io::detail {

struct PlyContent {
  std::vector<Vec3f> vertices;
  std::vector<Eigen::Vector3i> triangles;  ///< only when faces were requested
  std::size_t face_count = 0;              ///< faces in the file (before fanning)
};

/// Throws std::runtime_error naming the file and the line (ascii) or element and instance
/// (binary) on malformed or truncated input, and when a face refers to a missing vertex. Element
/// counts are checked against the bytes after the header before anything is allocated.
PlyContent readPly(const std::filesystem::path& path, bool read_faces);

}  // namespace vdbmap::io::detail
