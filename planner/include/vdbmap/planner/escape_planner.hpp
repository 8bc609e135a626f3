// Ways out of a start that no path may leave (occupied voxels within the clearance: a correction
// moved the map, drift brought the vehicle close to a wall, or thin structure shows up as the
// vehicle comes near): back along the way flown, or straight away from the occupied voxels.
// The exploration manager decides when to use them; this unit only finds the trajectories.
#pragma once

#include "vdbmap/planner/map_query.hpp"
#include "vdbmap/planner/trajectory.hpp"
#include "vdbmap/planner/vehicle_state.hpp"
#include "vdbmap/planner/viewpoint_history.hpp"

#include <Eigen/Geometry>

#include <deque>
#include <functional>
#include <limits>
#include <optional>
#include <vector>

namespace vdbmap::planner {

/// In ExplorationManagerConfig::escape the manager sets bounds_W, clearance_m and trajectory from its own
/// box, path clearance and trajectory parameters.
struct EscapeConfig {
  /// Ends stay inside this box (world frame); none: anywhere.
  std::optional<Eigen::AlignedBox3d> bounds_W;
  /// The clearance paths keep (an end must keep it in the current map); [0, 10]
  double clearance_m = 0.3;
  /// Flown positions kept (one voxel apart); [1, 1e6]
  int flown_positions_kept = 100;
  /// How far back along the way flown a retreat goes; [0, 100]
  double retreat_reach_m = 3.0;
  /// How far a straight escape looks for a clear point; (0, 10]
  double escape_reach_m = 1.0;
  TrajectoryConfig trajectory;
  /// Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};
using EscapeParams [[deprecated("renamed EscapeConfig")]] = EscapeConfig;

class EscapePlanner {
 public:
  /// Vets a retreat: its trajectory and the way it follows (the vehicle's position, then the
  /// positions flown, newest first, world frame).
  using RetreatCheck = std::function<bool(const Trajectory& trajectory, const std::vector<Vec3d>& way_W)>;

  /// Throws std::invalid_argument for invalid params.
  explicit EscapePlanner(const EscapeConfig& params);

  /// Records the vehicle's position at `stamp_s` (kept when a voxel or more from the last one
  /// recorded).
  void recordFlown(const Vec3d& p_W, double stamp_s, double voxel_m);
  /// The estimate frame moved: a position p is now shift * p.
  void shiftFrame(const Eigen::Isometry3d& shift);
  /// A loop closure corrected the past poses: each flown position becomes `corrected`'s position
  /// for it (given as a viewpoint with its stamp and a zero yaw). A frame shift alone keeps the way
  /// as odometry integrated it, which drifts over the tens of seconds a retreat may reach back;
  /// the corrected way is where the vehicle flew relative to the corrected map. Throws
  /// std::invalid_argument for a non-finite corrected position, leaving the way as it was.
  void correctHistory(const std::function<FlatPose(const FlownViewpoint&)>& corrected);

  /// A trajectory back along the way flown to the newest flown position at least a voxel away
  /// that keeps the clearance in `map` (with `farthest`, the farthest such), within
  /// retreat_reach_m of way and among the positions flown at `flown_since_s` or later, from rest.
  /// The vehicle flew that way, so the way's corridor reads free, occupied voxels too; the map
  /// only vets the end. A way flown long ago sits where odometry put it then, off by the drift
  /// since (what flown_since_s bounds). A trajectory that `accept` (when given) refuses is no
  /// retreat: e.g. one whose way what the camera saw since blocks. On success the positions
  /// flown after the end are forgotten, so that a retreat from there goes on backwards.
  std::optional<Trajectory> retreat(const MapQuery& map, const VehicleState& vehicle, bool farthest,
                                    const RetreatCheck& accept = {},
                                    double flown_since_s = -std::numeric_limits<double>::infinity());
  /// A trajectory straight away from the occupied voxels within the clearance to the nearest
  /// clear point within escape_reach_m (preferring the away direction) whose straight way
  /// crosses no occupied voxel.
  std::optional<Trajectory> straightEscape(const MapQuery& map, const VehicleState& vehicle) const;

 private:
  bool inBounds(const Vec3d& p_W) const { return !params_.bounds_W || params_.bounds_W->contains(p_W); }

  EscapeConfig params_;
  struct Flown {
    Vec3d p_W;
    double stamp_s;
  };
  std::deque<Flown> flown_;  ///< one voxel apart, newest last, in the current estimate frame
};

}  // namespace vdbmap::planner
