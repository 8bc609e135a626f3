// Odometry drift: the paper's model (Zhang et al., ICRA 2022, Table I), integrated at 200 Hz.
//
// Each step of dt = 1 / rate_hz the odometry integrates the vehicle's true motion plus an error:
//   - a velocity error v ~ N(mu_xyz, sigma2_xyz) per axis, in m/s, applied in the BODY frame
//     (x forward, y left, z up, yawed with the odometry's own heading), as a VIO's velocity
//     error is: the position error grows along the direction the vehicle believes it faces;
//   - a yaw-rate error w ~ N(mu_yaw, sigma2_yaw), in rad/s, added to the true yaw rate.
// So with the true body motion between two steps (dp_B in the body frame at the earlier step,
// dyaw), the odometry body pose advances as
//   p_odom += Rz(yaw_odom) (dp_B + v dt),   yaw_odom += dyaw + w dt,
// which is 4-DOF drift (x, y, z, yaw): roll and pitch stay true, as gravity keeps them observable.
//
// Table I lists (mu_xyz, sigma_xyz^2, mu_phi, sigma_phi^2); the second and fourth are VARIANCES
// (units m^2/s^2 and rad^2/s^2), so sigma = sqrt of them:
//   s1: (0, 0,    0,      0)
//   s2: (0, 2e-2, 0,      2e-2)
//   s3: (0, 5e-2, 1e-3,   5e-2)
//   s4: (0, 8e-2, 1.5e-3, 8e-2)
// As white noise integrated at 200 Hz, sigma2 = 5e-2 m^2/s^2 makes a position random walk of
// sqrt(sigma2 * dt) = 0.016 m per sqrt(s) per axis (0.16 m after 100 s), and the yaw error a walk
// of 0.016 rad per sqrt(s) plus mu_phi t. Draws are seeded and deterministic.
#pragma once

#include "vdbmap/sim/trajectory.hpp"
#include "vdbmap/types.hpp"

#include <cstdint>
#include <random>
#include <string>

namespace vdbmap::sim {

struct DriftConfig {
  double mu_xyz_mps = 0.0;          ///< mean velocity error per axis; [-10, 10]
  double sigma2_xyz_m2ps2 = 0.0;    ///< variance of the velocity error per axis; [0, 100]
  double mu_yaw_radps = 0.0;        ///< mean yaw-rate error; [-1, 1]
  double sigma2_yaw_rad2ps2 = 0.0;  ///< variance of the yaw-rate error; [0, 100]
  double rate_hz = 200.0;           ///< integration rate; [1, 10000]
  std::uint64_t seed = 1;

  void validate() const;
  /// Table I's level "s1".."s4" with the given seed; throws std::invalid_argument otherwise.
  static DriftConfig preset(const std::string& level, std::uint64_t seed = 1);
  bool isZero() const {
    return mu_xyz_mps == 0 && sigma2_xyz_m2ps2 == 0 && mu_yaw_radps == 0 && sigma2_yaw_rad2ps2 == 0;
  }
};

/// One step's error draw.
struct DriftIncrement {
  Vec3d v_B_mps = Vec3d::Zero();  ///< velocity error in the body frame
  double w_radps = 0.0;           ///< yaw-rate error
};

/// The drifting odometry of one vehicle, advanced step by step (online) with the true pose.
class DriftingOdometry {
 public:
  /// Odometry starts at the true pose `start` at time `t0_s`.
  DriftingOdometry(const DriftConfig& config, const FlatPose& start, double t0_s = 0.0);

  /// Advances to time t_s, where the vehicle's true pose is `truth`, by as many whole drift
  /// steps as fit (the true pose at each step is interpolated linearly from the previous call's;
  /// call at the drift rate or faster to follow curved motion exactly). Returns the odometry pose
  /// at t_s: the drift integrated up to the last step, plus the true motion since. Throws
  /// std::invalid_argument when t_s goes back in time or the pose is not finite.
  FlatPose advance(double t_s, const FlatPose& truth);

  /// The odometry pose at the last advance() (the start pose before any).
  const FlatPose& pose() const { return pose_; }
  double time() const { return t_; }
  std::size_t steps() const { return steps_; }

  /// Draws one step's error from the model's generator (what advance() uses per step).
  DriftIncrement drawIncrement();

  const DriftConfig& config() const { return config_; }

 private:
  void step(const FlatPose& from, const FlatPose& to, double dt, bool draw);

  DriftConfig config_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> unit_;
  double sigma_xyz_ = 0.0, sigma_yaw_ = 0.0;
  double t0_ = 0.0;      ///< start time; step k ends at t0_ + k dt
  double t_ = 0.0;       ///< time of the last advance()
  double t_step_ = 0.0;  ///< time of the last whole drift step
  FlatPose truth_step_;  ///< true pose at t_step_
  FlatPose odom_step_;   ///< odometry pose at t_step_
  FlatPose truth_;       ///< true pose at t_
  FlatPose pose_;        ///< odometry pose at t_
  std::size_t steps_ = 0;
};

}  // namespace vdbmap::sim
