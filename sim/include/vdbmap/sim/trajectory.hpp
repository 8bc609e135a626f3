// Time-parametrised vehicle trajectories: position and yaw as functions of time.
//
// The vehicle speaks the planner's vocabulary (planner/vehicle_state.hpp): a FlatPose (position
// and yaw about world z, the heading of the body x axis; roll and pitch stay zero) and a
// VehicleState. The body frame B is x forward, y left, z up; the camera is mounted on it (see
// flight.hpp). A SampledTrajectory is a dense record of VehicleStates in time (by default every
// 5 ms, the drift model's 200 Hz), linearly interpolated between samples; yaw is unwrapped
// (continuous, not limited to [-pi, pi]). Any planner can hand one over: sample its own
// representation (e.g. planner::Trajectory::sample) into a SampledTrajectory.
//
// timeParametrize turns a path of waypoints into a trajectory that stops at every waypoint and
// moves along straight segments with a trapezoidal speed profile (|a| <= a_max, |v| <= v_max), its
// yaw changing at a constant rate <= yaw_rate_max; when the turn needs longer than the move, the
// move is slowed to last as long.
#pragma once

#include "vdbmap/planner/vehicle_state.hpp"
#include "vdbmap/types.hpp"

#include <filesystem>
#include <vector>

namespace vdbmap::sim {

using planner::angleDifference;
using planner::FlatPose;
using planner::VehicleState;

/// The body pose T_W_B of a flat state (rotation about z by yaw).
Pose3d bodyPose(const Vec3d& position_W, double yaw_rad);
inline Pose3d bodyPose(const FlatPose& p) { return bodyPose(p.position_W, p.yaw_rad); }
inline Pose3d bodyPose(const VehicleState& s) { return bodyPose(s.position_W, s.yaw_rad); }

/// The paper's simulated vehicle: 2.0 m/s, 2.0 m/s^2, 0.9 rad/s.
struct MotionLimits {
  double v_max_mps = 2.0;           ///< (0, 100]
  double a_max_mps2 = 2.0;          ///< (0, 100]
  double yaw_rate_max_radps = 0.9;  ///< (0, 100]
  void validate() const;
};

/// Largest speed, acceleration and yaw rate of a trajectory, by finite differences of its samples
/// (independent of the v, a and yaw_rate fields they carry).
struct TrajectoryMaxima {
  double speed_mps = 0.0;
  double accel_mps2 = 0.0;
  double yaw_rate_radps = 0.0;
  bool within(const MotionLimits& limits, double relative_tolerance = 1e-3) const;
};

class SampledTrajectory {
 public:
  /// Appends the state at t_s; throws std::invalid_argument when a value is not finite or t_s is
  /// not greater than the last one's.
  void append(double t_s, const VehicleState& state);
  bool empty() const { return states_.empty(); }
  double startTime() const;
  double endTime() const;
  double duration() const { return empty() ? 0.0 : endTime() - startTime(); }
  /// The state at time t: linear interpolation between samples; before the start or after the end
  /// the first or last state with zero velocity, acceleration and yaw rate (hovering). Throws
  /// std::logic_error on an empty trajectory.
  VehicleState sample(double t_s) const;
  /// The samples: their times (increasing) and states, index by index.
  const std::vector<double>& times() const { return times_s_; }
  const std::vector<VehicleState>& states() const { return states_; }
  /// Path length in metres (sum of distances between consecutive samples).
  double length_m() const;
  TrajectoryMaxima maxima() const;

 private:
  std::vector<double> times_s_;
  std::vector<VehicleState> states_;
};

/// Stop-and-go time parametrisation of a path of poses (where to go, which way to face there; see
/// the file comment), sampled every dt_s from
/// t = start_time_s and at the exact time of every stop. Consecutive waypoints may coincide (a turn on the spot). Yaw
/// moves the short way round unless the waypoints' yaws are unwrapped on purpose (a difference beyond pi turns the long
/// way, so 2 pi is a full turn). Throws std::invalid_argument for an empty path, invalid limits or dt_s outside (0, 1].
SampledTrajectory timeParametrize(const std::vector<FlatPose>& path, const MotionLimits& limits, double dt_s = 0.005,
                                  double start_time_s = 0.0, bool shortest_yaw = true);

/// Reads a waypoint file: one waypoint a line, "x y z" or "x y z yaw" (metres, radians), '#'
/// starts a comment, blank lines are skipped. A missing yaw faces the next waypoint (the last one
/// keeps the previous yaw). Throws std::runtime_error "<file>:<line>: ..." on a malformed line or
/// a file with no waypoint.
std::vector<FlatPose> readWaypoints(const std::filesystem::path& path);

/// Writes waypoints as readWaypoints reads them (with yaw).
void writeWaypoints(const std::filesystem::path& path, const std::vector<FlatPose>& waypoints);

}  // namespace vdbmap::sim
