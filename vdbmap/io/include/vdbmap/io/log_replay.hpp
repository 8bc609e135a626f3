// Replaying a recorded log (or an imported dataset) through the Mapper, as the CLI's
// `integrate` and the Python bindings do.
//
// Frames are integrated in order (every `frame_stride`-th one) with the poses the log gives
// (odometry). A correction event (corrections/<t>.txt) is applied once the frame at its timestamp
// has been integrated: the poses it lists go to Mapper::updatePoses, and frames it does not list
// keep their pose. After each frame one budgeted re-integration cycle runs, nearest to the
// current sensor position first; at the end the queue is drained so the final map is corrected.
#pragma once

#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/mapper.hpp"

#include <functional>
#include <string>
#include <vector>

namespace vdbmap {

enum class OnBadFrame { Fail, Skip };
/// "fail" / "skip"; throws std::invalid_argument listing the choices.
OnBadFrame parseOnBadFrame(const std::string& text);

struct ReplayConfig {
  int frame_stride = 1;                    ///< integrate every k-th frame; [1, 1e6]
  OnBadFrame on_bad_frame = OnBadFrame::Fail;
  bool apply_corrections = true;           ///< false: ignore corrections/ whatever the mode
  /// Load the next frame while this one integrates (the default: a shorter run). false: load each
  /// frame before its cycle starts, so that decoding never shares the cores with a cycle, as for a
  /// peer timed that way (bench/open3d_7scenes.py).
  bool load_ahead = true;
  /// Called after every frame with (frames done, frames to do); for progress display.
  std::function<void(std::size_t, std::size_t)> progress;

  void validate() const;
};
using ReplayOptions [[deprecated("renamed ReplayConfig")]] = ReplayConfig;

struct BadFrame {
  std::size_t index = 0;
  std::string message;
};

struct ReplayResult {
  std::size_t frames_total = 0;        ///< frames the log lists, after the stride
  std::size_t frames_integrated = 0;
  std::size_t frames_skipped = 0;      ///< bad frames skipped (--on-bad-frame skip)
  std::vector<BadFrame> bad_frames;
  std::size_t correction_events = 0;   ///< events applied
  std::size_t points_invalid = 0;
  double integrate_s = 0.0;            ///< integration only (I/O and background work excluded)
  double ms_per_frame_median = 0.0;    ///< integration only
  double integrate_ms_max = 0.0;       ///< integration only
  /// Whole cycles (integration, corrections and the background cycle after each frame):
  double cycle_ms_median = 0.0;
  double ms_per_frame_p99 = 0.0;
  double ms_per_frame_max = 0.0;
  std::vector<double> cycle_ms;        ///< every frame's whole cycle, in order
  std::size_t background_frames = 0;   ///< frames the background cycles processed (both kinds)
  std::size_t pruned_frames_deintegrated = 0;
  double load_s = 0.0;                 ///< reading and decoding frame files (overlaps integration)
  double wall_s = 0.0;
};

/// Replays `source` into `mapper`. With OnBadFrame::Fail the first bad frame throws
/// io::BadFrameError naming the frame and file, and nothing is returned; with Skip it is listed
/// in the result and the rest is integrated.
ReplayResult replayLog(const io::FrameSource& source, Mapper& mapper, const ReplayConfig& options);

}  // namespace vdbmap
