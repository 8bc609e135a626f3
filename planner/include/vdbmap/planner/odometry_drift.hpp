// What the vehicle's odometry is expected to drift, as a VIO's noise spec declares it: a random
// walk in position (per axis) and in yaw, each with a bias (4-DOF drift: gravity keeps roll and
// pitch observable).
//
// The safety layer (exploration_manager.hpp, SafetyConfig::odometry) reads it to size the window
// of recent frames it trusts: a frame t seconds old sits, relative to the vehicle's current
// estimate, where t seconds of drift moved it. A point lever_m from the camera moves by about
//   displacement_m(t, lever_m) = sqrt(3) (q_p sqrt(t) + |b_p| t) + lever_m (q_yaw sqrt(t) + |b_yaw| t)
// (one sigma of the position error over three axes, plus the arc of the yaw error). When the
// vehicle flies path_m meanwhile, the yaw error turns each metre of it, and the vehicle's estimate
// moves from the frame's by about path_m (q_yaw sqrt(t / 3) + |b_yaw| t / 2) more (a yaw random
// walk integrated along a path flown at constant speed).
#pragma once

namespace vdbmap::planner {

struct OdometryDrift {
  double position_m_per_sqrt_s = 0.0;  ///< position random walk per axis (one sigma after 1 s); [0, 10]
  double position_bias_m_per_s = 0.0;  ///< velocity bias per axis, either sign; [-10, 10]
  double yaw_rad_per_sqrt_s = 0.0;     ///< yaw random walk (one sigma after 1 s); [0, 10]
  double yaw_bias_rad_per_s = 0.0;     ///< yaw-rate bias, either sign; [-1, 1]

  void validate() const;

  /// The expected displacement (above) after t_s >= 0 seconds of a point lever_m >= 0 from the
  /// camera. Throws std::invalid_argument for a negative or non-finite argument.
  double displacement_m(double t_s, double lever_m) const;
  /// The same when the vehicle flies path_m >= 0 metres in those t_s seconds (above).
  double displacement_m(double t_s, double lever_m, double path_m) const;

  /// The expected position error along one axis (one sigma, e.g. vertical) after t_s >= 0
  /// seconds: position_m_per_sqrt_s sqrt(t_s) + |position_bias_m_per_s| t_s. Throws
  /// std::invalid_argument for a negative or non-finite t_s.
  double axisDisplacement_m(double t_s) const;

  /// The longest time in [min_s, max_s] whose displacement_m(t, lever_m) stays within
  /// tolerance_m: max_s when the drift stays within it that long, min_s when even min_s exceeds
  /// it. Throws std::invalid_argument unless 0 <= min_s <= max_s and the other arguments are
  /// finite and >= 0.
  double longestWithin(double tolerance_m, double lever_m, double min_s, double max_s) const;
};

}  // namespace vdbmap::planner
