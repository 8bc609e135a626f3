// Writing outputs so that a failed run never replaces a good file with a truncated one.
#pragma once

#include <filesystem>
#include <functional>
#include <ostream>

namespace vdbmap {

/// Calls `write` on a stream to a temporary file beside `path` (same folder, so the rename is
/// atomic), checks the stream, and renames the temporary over `path`. On any failure the
/// temporary is removed, `path` is left as it was, and std::runtime_error names the file.
void writeFileAtomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write);

/// A temporary path beside `path` for writers that must write by file name (OpenVDB's io::File);
/// commit it with commitTemporary(), or remove it with std::filesystem::remove on failure.
std::filesystem::path temporaryPathFor(const std::filesystem::path& path);
void commitTemporary(const std::filesystem::path& tmp, const std::filesystem::path& path);

}  // namespace vdbmap
