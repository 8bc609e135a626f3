// A walk over a .vdb file's header, file metadata and grid descriptors that checks every length
// and offset they declare against the file's size, before OpenVDB reads it: OpenVDB allocates what
// a string length says, so a truncated or damaged file could otherwise take gigabytes.
#pragma once

#include <filesystem>

namespace vdbmap::internal {

/// Throws FileError naming the file, the entry and the declared size when a length or offset
/// reaches beyond the file, a fixed-size metadata value declares another size than OpenVDB reads,
/// or the file is older than OpenVDB's format 220 or has no grid offsets (neither can be checked).
void checkVdbFileStructure(const std::filesystem::path& path);

}  // namespace vdbmap::internal
