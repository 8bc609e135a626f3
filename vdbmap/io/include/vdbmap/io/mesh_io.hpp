// Reading and writing triangle meshes and their vertices (PLY ascii/binary, OBJ, OFF).
#pragma once

#include "vdbmap/triangle_mesh.hpp"

#include <filesystem>

namespace vdbmap::io {

/// Reads a triangle mesh from PLY (ascii, binary little/big endian), OBJ or OFF, chosen by the
/// file's extension. Polygons are fanned into triangles; degenerate faces are kept (callers that
/// need clean meshes filter them). Throws std::runtime_error naming the file and line or element
/// on malformed input, and std::ios_base::failure-like runtime_errors when it cannot be opened.
TriangleMesh readTriangleMesh(const std::filesystem::path& path);

/// Writes a binary little-endian PLY with float vertices and int32 triangle indices. The file is
/// written to a temporary name next to `path` and renamed, so a failed write never leaves a
/// truncated file where a good one was.
void writePlyMesh(const std::filesystem::path& path, const TriangleMesh& mesh);

}  // namespace vdbmap::io
