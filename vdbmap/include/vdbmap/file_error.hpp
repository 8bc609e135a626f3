// The exception of everything that reads or writes files, the map's own .vdb files included.
#pragma once

#include <stdexcept>

namespace vdbmap {

/// A file or folder that cannot be opened, read or written, or whose content is malformed (bad
/// header, truncated data, a listing that does not parse). The message names the file and, where
/// it helps, the line or element. Callers that only care about "something failed" can keep
/// catching std::runtime_error; the Python bindings turn this type into OSError.
class FileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace vdbmap
