// A walk over a whole .vdb file before OpenVDB reads it: header, file metadata, grid descriptors,
// and every grid's metadata, transform, tree topology and value chunks, each length and count
// checked against the bytes that must hold it. OpenVDB 10 trusts what a file says: it allocates
// the lengths it reads, reads past a grid's end into uninitialised sizes, and lets Blosc read what
// a chunk header declares. After this walk it reads only what the file holds.
#pragma once

#include <filesystem>

namespace vdbmap::internal {

/// Throws FileError naming the file and the entry (grid, node, leaf, chunk) when a length, count
/// or offset reaches beyond the bytes that must hold it, a fixed-size metadata value declares
/// another size than OpenVDB reads, a Blosc chunk's header disagrees with its size or with the
/// values it must hold, or the file holds what this walk does not know: OpenVDB file formats
/// before 222 (OpenVDB 3.0), files without grid offsets, frustum transforms, and trees other than
/// float, double, int32, int64 and vec3 with OpenVDB's standard 5-4-3 nodes.
void checkVdbFileStructure(const std::filesystem::path& path);

}  // namespace vdbmap::internal
