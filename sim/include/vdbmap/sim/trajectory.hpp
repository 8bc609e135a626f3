// Time-parametrised vehicle trajectories: position and yaw as functions of time.
//
// The vehicle is flat: a position p_W and a yaw about world z (the heading of the body x axis);
// roll and pitch stay zero, as for a multicopter flying slowly. The body frame B is x forward,
// y left, z up; the camera is mounted on it (see flight.hpp). A Trajectory is a densely sampled
// record of FlatStates (by default every 5 ms, the drift model's 200 Hz), linearly interpolated
// between samples; yaw is unwrapped (continuous, not limited to [-pi, pi]). Any planner can hand
// one over: sample its own representation into a Trajectory.
//
// timeParametrize turns a path of waypoints into a trajectory that stops at every waypoint and
// moves along straight segments with a trapezoidal speed profile (|a| <= a_max, |v| <= v_max), its
// yaw changing at a constant rate <= yaw_rate_max; when the turn needs longer than the move, the
// move is slowed to last as long.
#pragma once

#include "vdbmap/types.hpp"

#include <filesystem>
#include <vector>

namespace vdbmap::sim {

/// The vehicle's state at a time.
struct FlatState {
  double t_s = 0.0;
  Vec3d p_W = Vec3d::Zero();
  Vec3d v_W = Vec3d::Zero();
  Vec3d a_W = Vec3d::Zero();
  double yaw = 0.0;       ///< radians, unwrapped
  double yaw_rate = 0.0;  ///< rad/s
};

/// A flat body pose: position and yaw (what drift, loop closure and the pose graph act on).
struct FlatPose {
  Vec3d p_W = Vec3d::Zero();
  double yaw = 0.0;
};

/// The body pose T_W_B of a flat state (rotation about z by yaw).
Pose3d bodyPose(const Vec3d& p_W, double yaw);
inline Pose3d bodyPose(const FlatState& s) { return bodyPose(s.p_W, s.yaw); }
inline Pose3d bodyPose(const FlatPose& p) { return bodyPose(p.p_W, p.yaw); }
inline FlatPose flatPose(const FlatState& s) { return {s.p_W, s.yaw}; }

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

class Trajectory {
 public:
  /// Appends a state; throws std::invalid_argument when a value is not finite or t_s is not
  /// greater than the last one's.
  void append(const FlatState& state);
  bool empty() const { return samples_.empty(); }
  double startTime() const;
  double endTime() const;
  double duration() const { return empty() ? 0.0 : endTime() - startTime(); }
  /// The state at time t: linear interpolation between samples; before the start or after the end
  /// the first or last state with zero velocity, acceleration and yaw rate (hovering). Throws
  /// std::logic_error on an empty trajectory.
  FlatState sample(double t) const;
  const std::vector<FlatState>& samples() const { return samples_; }
  /// Path length in metres (sum of distances between consecutive samples).
  double length_m() const;
  TrajectoryMaxima maxima() const;

 private:
  std::vector<FlatState> samples_;
};

/// A point of a path: where to go and which way to face there.
struct Waypoint {
  Vec3d p_W = Vec3d::Zero();
  double yaw = 0.0;
};

/// Stop-and-go time parametrisation of a path (see the file comment), sampled every dt_s from
/// t = start_time_s and at the exact time of every stop. Consecutive waypoints may coincide (a turn on the spot). Yaw
/// moves the short way round unless the waypoints' yaws are unwrapped on purpose (a difference beyond pi turns the long
/// way, so 2 pi is a full turn). Throws std::invalid_argument for an empty path, invalid limits or dt_s outside (0, 1].
Trajectory timeParametrize(const std::vector<Waypoint>& path, const MotionLimits& limits, double dt_s = 0.005,
                           double start_time_s = 0.0, bool shortest_yaw = true);

/// Reads a waypoint file: one waypoint a line, "x y z" or "x y z yaw" (metres, radians), '#'
/// starts a comment, blank lines are skipped. A missing yaw faces the next waypoint (the last one
/// keeps the previous yaw). Throws std::runtime_error "<file>:<line>: ..." on a malformed line or
/// a file with no waypoint.
std::vector<Waypoint> readWaypoints(const std::filesystem::path& path);

/// Writes waypoints as readWaypoints reads them (with yaw).
void writeWaypoints(const std::filesystem::path& path, const std::vector<Waypoint>& waypoints);

/// The shortest signed angle from `from` to `to`, in (-pi, pi].
double angleDifference(double to, double from);

}  // namespace vdbmap::sim
