// Minimum-time, collision-free trajectories along a planned path.
//
// Method: the path's corners are rounded with circular arcs, and the rounded path is then
// parametrised in time optimally for the limits (forward-backward integration of the speed
// profile on a fine grid, as in time-optimal path parametrisation). Why this and not FUEL's
// B-spline optimisation:
//  - the limits hold exactly, at every instant, not only at control points: on straight pieces
//    the vehicle uses all of a_max along the path; on arcs the acceleration is split (the
//    "friction circle") into a normal part <= normal_acc_share * a_max (speed capped by
//    v^2 / radius) and a tangential part <= sqrt(1 - share^2) * a_max, so |a| <= a_max; speed is
//    piecewise linear in time between grid nodes, so |v| <= v_max between samples too;
//  - it stays collision-free by construction: the path's segments (and any lead-in) are checked
//    with the path planner's capsule test, straight pieces are parts of them, and each arc is
//    checked densely with the same clearance and tightened (halved) until it passes; a corner that
//    cannot be rounded becomes a stop-and-turn corner through the vertex;
//  - it needs no distance field, no gradient and no solver tuning, it is deterministic, and it
//    takes well under a millisecond.
// The cost: acceleration may jump where a straight piece meets an arc (no jerk limit), and the
// motion is time-optimal along the rounded path, not over all paths.
//
// Start state: when the vehicle is moving, the trajectory starts with exactly its velocity when it
// can: along the path if the velocity points along it and there is room to brake, else through a
// lead-in along the current velocity (if clear), curving onto the path: first one whose arc starts
// at the vehicle and turns at its speed (lead_in_at_speed), then short straight ones that brake
// into a tighter arc, shortest first. When neither works
// (e.g. flying at a wall) the status says the start velocity was reduced. The trajectory ends at
// rest at the last waypoint.
//
// Yaw, |yaw rate| <= yaw_rate_max and |yaw acceleration| <= yaw_acc_max throughout, one of two ways:
//  - by default a trapezoidal yaw-rate profile from the current yaw to the goal yaw, spread over
//    the whole motion;
//  - with yaw_along_travel, the camera faces the way: the yaw tracks the direction toward where
//    the vehicle will be yaw_lead_s later (time-optimally within the limits, sampled every 10 ms),
//    and turns to the goal yaw only when the time left in the motion is what that turn needs,
//    ending within 1 mrad of it. Until the way lies within start_facing_rad of the yaw, the
//    vehicle's stopping point stays within free_way_m: a trajectory from rest turns on the spot
//    first as long as that needs (motionStart()), a moving one slows down over free_way_m.
// Either way, if turning takes longer than moving, the vehicle waits at the goal until it has
// turned (this also turns it on the spot).
#pragma once

#include "vdbmap/planner/map_query.hpp"
#include "vdbmap/planner/vehicle_state.hpp"

#include <vector>

namespace vdbmap::planner {

struct TrajectoryConfig {
  double v_max_m_s = 2.0;             ///< (0, 100]
  double a_max_m_s2 = 2.0;            ///< (0, 100]
  double yaw_rate_max_rad_s = 0.9;    ///< (0, 100]
  double yaw_acc_max_rad_s2 = 2.0;    ///< smooths yaw-rate changes; (0, 1000]
  /// Share of a_max that turning may use on arcs (the rest, sqrt(1 - share^2), speeds up or slows
  /// down there); (0, 1)
  double normal_acc_share = 0.8;
  /// An arc starts at most this fraction of each adjacent segment before the corner; (0, 0.5]
  double corner_fraction = 0.45;
  /// Spacing of the speed profile's grid; (0, 1]
  double ds_m = 0.05;
  /// Clearance test of arcs and lead-ins: as PathConfig (use the same values); [0, 5] and [0, 1]
  double clearance_m = 0.3;
  double check_step_m = 0.0;          ///< 0 = half a voxel
  /// How often an arc that is not clear is halved before the corner becomes a stop; [0, 30]
  int corner_shrink_steps = 6;
  /// Face the direction of travel while moving (see the header comment), e.g. so that a camera
  /// sees the way before the vehicle flies it.
  bool yaw_along_travel = false;
  /// With yaw_along_travel: the yaw faces the point this much later on the trajectory; (0, 10]
  double yaw_lead_s = 0.5;
  /// With yaw_along_travel, from rest: the vehicle faces the way (within this angle of the yaw;
  /// below a camera's half field of view, so that it sees the way first) before it flies more than
  /// free_way_m; [0, pi]
  double start_facing_rad = 0.5;
  /// With yaw_along_travel: the length of the way, from its start, that needs no facing (e.g.
  /// what a camera saw free moments ago). Until the vehicle faces the way, its stopping point
  /// stays within this length: from rest, the motion starts while it still turns, as early as
  /// that allows (0 = it turns on the spot first); moving, it cruises over this length at the
  /// highest speed that allows it, when it can stop within it at all; >= 0
  double free_way_m = 0.0;
  /// A moving start whose velocity leaves the path first tries a lead-in whose arc starts at the
  /// vehicle and turns onto the path at the current speed (radius v^2 / (normal_acc_share
  /// a_max)), where that arc is clear, before straight lead-ins that brake into a tighter turn.
  bool lead_in_at_speed = true;

  void validate() const;
};
using TrajectoryParams [[deprecated("renamed TrajectoryConfig")]] = TrajectoryConfig;

/// A time-parametrised trajectory: sample(t) for t in [0, duration()] (clamped outside).
class Trajectory {
 public:
  /// Holding still at the origin with zero yaw, duration 0.
  Trajectory() = default;
  /// Holding still at p_W with `yaw_rad`, duration 0.
  static Trajectory hold(const Vec3d& p_W, double yaw_rad);

  double duration() const { return duration_s_; }
  /// The commanded state at t_s (world frame).
  VehicleState sample(double t_s) const;

  /// When the motion ends (the rest of duration() is turning in place at the goal).
  double motionDuration() const { return motion_s_; }
  /// When the motion starts: 0, or the time a trajectory from rest turns on the spot first
  /// (TrajectoryConfig::start_facing_rad, free_way_m).
  double motionStart() const { return node_t_.empty() ? 0.0 : node_t_.front(); }
  double length_m() const { return node_s_.empty() ? 0.0 : node_s_.back(); }
  /// The polyline the rounded path was built on (the lead-in point included, if any).
  const std::vector<Vec3d>& corners() const { return corners_; }
  /// The velocity at t = 0.
  Vec3d startVelocity() const;
  /// Number of corners that could not be rounded and are taken stopping.
  int stopCorners() const { return stop_corners_; }

 private:
  friend class TrajectoryBuilder;
  struct Piece {
    double s0 = 0.0, length = 0.0;
    bool arc = false;
    Vec3d p0 = Vec3d::Zero(), dir = Vec3d::UnitX();  ///< line: start and unit direction
    Vec3d centre = Vec3d::Zero(), e0 = Vec3d::UnitX(), e1 = Vec3d::UnitY();  ///< arc: centre + R (e0 cos + e1 sin)
    double radius = 0.0;
    bool stop_at_end = false;  ///< the vehicle comes to rest at its end (the goal, a corner not rounded)
  };
  /// Position, unit tangent and curvature vector at arc length s.
  void geometry(double s, Vec3d& p, Vec3d& tangent, Vec3d& curvature) const;
  void sampleYaw(double t, double& yaw, double& rate) const;

  std::vector<Piece> pieces_;
  std::vector<double> node_s_, node_v_, node_t_;  ///< speed profile on the grid
  std::vector<Vec3d> corners_;
  Vec3d end_W_ = Vec3d::Zero();
  double motion_s_ = 0.0;
  double duration_s_ = 0.0;
  int stop_corners_ = 0;
  // Yaw: trapezoidal rate profile of total angle `yaw_delta_` over duration_s_; or, when
  // yaw_track_ is not empty, the tracked yaw (unwrapped) and its rate every kYawTrackStep_s, with
  // constant yaw acceleration between samples.
  double yaw0_ = 0.0, yaw_delta_ = 0.0, yaw_acc_ = 0.0, yaw_peak_rate_ = 0.0, yaw_ramp_s_ = 0.0;
  std::vector<double> yaw_track_, yaw_rate_track_;
};

enum class TrajectoryStatus {
  Ok,
  StartVelocityReduced,  ///< a valid trajectory, but it starts slower than the vehicle moves (no
                         ///< clear lead-in could brake it in time)
  PathNotClear,          ///< a path segment failed the clearance test: no trajectory
};
const char* toString(TrajectoryStatus s);

struct TrajectoryResult {
  TrajectoryStatus status = TrajectoryStatus::PathNotClear;
  Trajectory trajectory;
  bool ok() const { return status != TrajectoryStatus::PathNotClear; }
};

/// A trajectory from the vehicle's state along `path_W` (e.g. PathResult::waypoints; its first
/// point must be the vehicle's position within 1 mm, else std::invalid_argument) to rest at its
/// last point with `goal_yaw_rad`. A single-point path turns on the spot.
TrajectoryResult planTrajectory(const std::vector<Vec3d>& path_W, const VehicleState& start, double goal_yaw_rad,
                                const MapQuery& map, const TrajectoryConfig& params = {});

}  // namespace vdbmap::planner
