// Exceptions of the file layer that callers may want to tell apart.
#pragma once

#include "vdbmap/file_error.hpp"

#include <cstddef>
#include <string>

namespace vdbmap::io {

/// A problem with one frame of a dataset (missing, corrupt or wrongly sized file, invalid pose):
/// thrown by FrameSource::load(i) for that frame only, so that a caller can skip the frame
/// (`--on-bad-frame skip`) or stop. The message names the frame and its file or line.
class BadFrameError : public FileError {
 public:
  BadFrameError(std::size_t frame_index, const std::string& message)
      : FileError(message), frame_index_(frame_index) {}
  std::size_t frameIndex() const { return frame_index_; }

 private:
  std::size_t frame_index_;
};

}  // namespace vdbmap::io
