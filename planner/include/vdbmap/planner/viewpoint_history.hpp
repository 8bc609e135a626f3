// The viewpoints the vehicle flew through (position, yaw, stamp), for active loop closure
// (Zhang et al. 2022, Sect. IV-D): places it could go back to so that a loop closes. Kept in a
// KD-tree over position (point_index.hpp) that grows as the vehicle flies.
//
// The vehicle offers its pose every cycle; a pose is recorded only when it moved or turned enough
// since the last recorded one, so hovering adds nothing and the spacing stays well below the
// loop detector's tolerance (the simulator's: 0.5 m, 0.2 rad).
#pragma once

#include "vdbmap/planner/point_index.hpp"
#include "vdbmap/planner/vehicle_state.hpp"

#include <cstddef>
#include <functional>
#include <optional>
#include <vector>

namespace vdbmap::planner {

struct ViewpointHistoryConfig {
  /// Record a pose when it is at least this far from the last recorded one; [0, 100]. A quarter of
  /// the loop detector's 0.5 m distance: every flown position has a recorded one within 0.125 m.
  double record_spacing_m = 0.25;
  /// ... or when its yaw differs by at least this much; (0, pi]. Half the detector's 0.2 rad.
  double record_yaw_step_rad = 0.1;
  void validate() const;
};
using ViewpointHistoryParams [[deprecated("renamed ViewpointHistoryConfig")]] = ViewpointHistoryConfig;

/// One recorded viewpoint: where the vehicle was (world frame, as the planner estimated it, or as
/// corrected later) and when.
struct FlownViewpoint {
  Vec3d position_W = Vec3d::Zero();
  double yaw_rad = 0.0;
  double stamp_s = 0.0;
};

class ViewpointHistory {
 public:
  explicit ViewpointHistory(const ViewpointHistoryConfig& params = {});

  /// Offers the vehicle's pose at `stamp_s`; records it (and returns true) when it is the first,
  /// or moved at least record_spacing_m or turned at least record_yaw_step_rad since the last
  /// recorded one. Throws std::invalid_argument for non-finite values or a stamp earlier than the
  /// previous offer's.
  bool offer(const Vec3d& position_W, double yaw_rad, double stamp_s);

  std::size_t size() const { return viewpoints_.size(); }
  bool empty() const { return viewpoints_.empty(); }
  const FlownViewpoint& operator[](std::size_t i) const { return viewpoints_.at(i); }
  const std::vector<FlownViewpoint>& viewpoints() const { return viewpoints_; }

  /// Indices of the recorded viewpoints within radius_m of p (see PointIndex::withinRadius),
  /// ascending, i.e. oldest first.
  std::vector<std::size_t> withinRadius(const Vec3d& p_W, double radius_m) const;

  /// Moves every recorded viewpoint to `corrected(v)` (e.g. its pose after a pose-graph
  /// correction, looked up by stamp) and rebuilds the KD-tree; stamps and indices stay.
  void correct(const std::function<FlatPose(const FlownViewpoint&)>& corrected);

  const ViewpointHistoryConfig& params() const { return params_; }

 private:
  ViewpointHistoryConfig params_;
  std::vector<FlownViewpoint> viewpoints_;
  PointIndex index_;
  std::optional<double> last_offer_s_;
};

}  // namespace vdbmap::planner
