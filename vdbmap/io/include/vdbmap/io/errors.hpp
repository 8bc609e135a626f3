// Exceptions of the file layer that callers may want to tell apart.
#pragma once

#include "vdbmap/file_error.hpp"

#include <cstddef>
#include <string>
#include <string_view>

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

/// `text` with every control byte (below 0x20, and 0x7f) written as \xNN, so that file content
/// quoted in an error message cannot move the terminal's cursor, change its colours or hide text;
/// with `keep_line_breaks`, newlines and tabs stay (for whole messages printed to a terminal).
std::string escapeControl(std::string_view text, bool keep_line_breaks = false);

}  // namespace vdbmap::io
