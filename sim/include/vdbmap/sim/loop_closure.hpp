// Simulated loop-closure detection, as the authors' mock loop does it: a loop closes when the
// vehicle's TRUE pose comes back within a distance and a yaw of a true pose recorded more than
// `min_age_s` earlier, at most once every `min_interval_s` (defaults: 0.5 m, 0.2 rad, 15 s, 5 s).
// Beyond the authors' test we also require that the two views overlap: a real place-recognition
// front end needs common structure in both images, so a revisit facing a blank wall from the
// other side of it does not count.
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/sim/trajectory.hpp"
#include "vdbmap/sim/world.hpp"
#include "vdbmap/types.hpp"

#include <cstddef>
#include <functional>
#include <optional>
#include <vector>

namespace vdbmap::sim {

struct LoopClosureConfig {
  double max_distance_m = 0.5;  ///< true positions at most this far apart; (0, 100]
  double max_yaw_rad = 0.2;     ///< true yaws at most this far apart; (0, pi]
  double min_age_s = 15.0;      ///< the older frame at least this much older; [0, 1e6]
  double min_interval_s = 5.0;  ///< at most one loop closure per this time; [0, 1e6]
  /// Fraction of the current frame's surface samples the older camera sees too; [0, 1]
  double min_view_overlap = 0.5;
  int overlap_pixel_stride = 16;  ///< sample every k-th pixel per direction for the overlap; [1, 1000]
  int max_overlap_checks = 8;     ///< candidates (nearest first) tested per frame; [1, 1000]

  void validate() const;
};

/// A detected loop: the current frame matches an older one.
struct LoopClosure {
  std::size_t old_frame = 0;
  std::size_t new_frame = 0;
  double distance_m = 0.0;
  double yaw_difference_rad = 0.0;
  double view_overlap = 0.0;
};

/// Fraction of the surface points seen in `depth_now` (every `stride`-th pixel, valid depths only)
/// that a camera at T_W_S_old would see too: inside its image and range, and not occluded in the
/// world (a ray from the old camera reaches within `occlusion_tolerance_m` of the point). 0 when
/// `depth_now` has no valid pixel.
double viewOverlap(const World& world, const CameraIntrinsics& K, double max_range_m, const DepthImage& depth_now,
                   const Pose3d& T_W_S_now, const Pose3d& T_W_S_old, int stride, double occlusion_tolerance_m = 0.05);

class LoopDetector {
 public:
  explicit LoopDetector(const LoopClosureConfig& config = {});

  /// Overlap of the current view with the view of an older frame (by frame index), in [0, 1].
  using OverlapFn = std::function<double(std::size_t old_frame)>;

  /// Records frame `frame` (indices increasing, times increasing) at its true body pose and
  /// returns the loop it closes, if any. `overlap` is called only for candidates that pass the
  /// distance, yaw, age and interval tests, nearest first.
  std::optional<LoopClosure> addFrame(std::size_t frame, double t_s, const FlatPose& truth, const OverlapFn& overlap);

  const LoopClosureConfig& config() const { return config_; }
  std::size_t detections() const { return detections_; }

 private:
  struct Entry {
    std::size_t frame;
    double t_s;
    FlatPose truth;
  };
  LoopClosureConfig config_;
  std::vector<Entry> history_;
  std::optional<double> last_loop_t_s_;
  std::size_t detections_ = 0;
};

}  // namespace vdbmap::sim
