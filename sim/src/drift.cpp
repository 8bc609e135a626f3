#include "vdbmap/sim/drift.hpp"

#include <cmath>
#include <stdexcept>

namespace vdbmap::sim {

void DriftConfig::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("DriftConfig." + what); };
  if (!(mu_xyz_mps >= -10.0 && mu_xyz_mps <= 10.0)) fail("mu_xyz_mps must be in [-10, 10]");
  if (!(sigma2_xyz_m2ps2 >= 0.0 && sigma2_xyz_m2ps2 <= 100.0)) fail("sigma2_xyz_m2ps2 must be in [0, 100]");
  if (!(mu_yaw_radps >= -1.0 && mu_yaw_radps <= 1.0)) fail("mu_yaw_radps must be in [-1, 1]");
  if (!(sigma2_yaw_rad2ps2 >= 0.0 && sigma2_yaw_rad2ps2 <= 100.0)) fail("sigma2_yaw_rad2ps2 must be in [0, 100]");
  if (!(rate_hz >= 1.0 && rate_hz <= 10000.0)) fail("rate_hz must be in [1, 10000]");
}

DriftConfig DriftConfig::preset(const std::string& level, std::uint64_t seed) {
  DriftConfig c;
  c.seed = seed;
  if (level == "s1") return c;
  if (level == "s2") {
    c.sigma2_xyz_m2ps2 = 2e-2, c.sigma2_yaw_rad2ps2 = 2e-2;
  } else if (level == "s3") {
    c.sigma2_xyz_m2ps2 = 5e-2, c.mu_yaw_radps = 1e-3, c.sigma2_yaw_rad2ps2 = 5e-2;
  } else if (level == "s4") {
    c.sigma2_xyz_m2ps2 = 8e-2, c.mu_yaw_radps = 1.5e-3, c.sigma2_yaw_rad2ps2 = 8e-2;
  } else {
    throw std::invalid_argument("drift level must be s1, s2, s3 or s4, got '" + level + "'");
  }
  return c;
}

DriftingOdometry::DriftingOdometry(const DriftConfig& config, const FlatPose& start, double t0_s)
    : config_(config), rng_(config.seed), unit_(0.0, 1.0) {
  config_.validate();
  if (!start.position_W.allFinite() || !std::isfinite(start.yaw_rad) || !std::isfinite(t0_s))
    throw std::invalid_argument("DriftingOdometry: non-finite start pose or time");
  sigma_xyz_ = std::sqrt(config_.sigma2_xyz_m2ps2);
  sigma_yaw_ = std::sqrt(config_.sigma2_yaw_rad2ps2);
  t0_ = t_ = t_step_ = t0_s;
  truth_ = truth_step_ = odom_step_ = pose_ = start;
}

DriftIncrement DriftingOdometry::drawIncrement() {
  DriftIncrement inc;
  for (int a = 0; a < 3; ++a) inc.v_B_mps[a] = config_.mu_xyz_mps + sigma_xyz_ * unit_(rng_);
  inc.w_radps = config_.mu_yaw_radps + sigma_yaw_ * unit_(rng_);
  return inc;
}

namespace {
/// Moves `odom` by the true motion from `from` to `to`, expressed in the true body frame at
/// `from` and replayed in the odometry's own body frame.
FlatPose replayMotion(const FlatPose& odom, const FlatPose& from, const FlatPose& to, const Vec3d& extra_B,
                      double extra_yaw) {
  const Vec3d dp_B = Eigen::AngleAxisd(-from.yaw_rad, Vec3d::UnitZ()) * (to.position_W - from.position_W);
  FlatPose out;
  out.position_W = odom.position_W + Eigen::AngleAxisd(odom.yaw_rad, Vec3d::UnitZ()) * (dp_B + extra_B);
  out.yaw_rad = odom.yaw_rad + angleDifference(to.yaw_rad, from.yaw_rad) + extra_yaw;
  return out;
}
}  // namespace

FlatPose DriftingOdometry::advance(double t_s, const FlatPose& truth) {
  if (!std::isfinite(t_s) || !truth.position_W.allFinite() || !std::isfinite(truth.yaw_rad))
    throw std::invalid_argument("DriftingOdometry::advance: non-finite time or pose");
  if (t_s < t_)
    throw std::invalid_argument("DriftingOdometry::advance: time " + std::to_string(t_s) + " is before " +
                                std::to_string(t_));
  const double dt = 1.0 / config_.rate_hz;
  const double span = t_s - t_;
  const double dyaw_span = angleDifference(truth.yaw_rad, truth_.yaw_rad);
  // Whole steps up to t_s, at times t0 + k dt (counted, not accumulated, so none is lost).
  while (t0_ + double(steps_ + 1) * dt <= t_s + 1e-9) {
    const double t_next = t0_ + double(steps_ + 1) * dt;
    const double w = span > 0.0 ? std::clamp((t_next - t_) / span, 0.0, 1.0) : 1.0;
    FlatPose truth_next;
    truth_next.position_W = (1.0 - w) * truth_.position_W + w * truth.position_W;
    truth_next.yaw_rad = truth_.yaw_rad + w * dyaw_span;
    const DriftIncrement e = drawIncrement();
    odom_step_ = replayMotion(odom_step_, truth_step_, truth_next, e.v_B_mps * dt, e.w_radps * dt);
    truth_step_ = truth_next;
    t_step_ = t_next;
    ++steps_;
  }
  // Since the last whole step the odometry follows the true motion without error.
  pose_ = replayMotion(odom_step_, truth_step_, truth, Vec3d::Zero(), 0.0);
  t_ = t_s;
  truth_ = truth;
  return pose_;
}

}  // namespace vdbmap::sim
