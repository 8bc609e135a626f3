// A walk over a .vdb file's header, file metadata and grid descriptors that checks every length
// and offset they declare against the file's size, before OpenVDB reads it: OpenVDB allocates what
// a string length says, so a truncated or damaged file could otherwise take gigabytes.
#pragma once

#include <filesystem>

namespace vdbmap::internal {

/// Throws FileError naming the file, the entry and the declared size when a length or offset
/// reaches beyond the file. Files of a format older than OpenVDB's 220 are left to OpenVDB.
void checkVdbFileStructure(const std::filesystem::path& path);

}  // namespace vdbmap::internal
