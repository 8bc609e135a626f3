// Odometry drift (sim/drift.hpp): the paper's Table I model at 200 Hz, and the drift it declares to the planner.
#include <catch2/catch.hpp>

#include "vdbmap/sim/drift.hpp"
#include "vdbmap/sim/exploration.hpp"
#include "vdbmap/sim/trajectory.hpp"

#include <cmath>

using namespace vdbmap;
using namespace vdbmap::sim;

namespace {
/// A curvy true path: a circle of radius 3 m with a climbing, turning vehicle.
FlatPose truthAt(double t) {
  return {Vec3d(3.0 * std::cos(0.2 * t), 3.0 * std::sin(0.2 * t), 1.0 + 0.2 * std::sin(0.5 * t)),
          0.2 * t + 0.5 * std::sin(t)};
}
}  // namespace

TEST_CASE("Table I presets: s1 to s4 as listed, variances in the sigma2 fields", "[sim][drift]") {
  const DriftConfig s1 = DriftConfig::preset("s1"), s2 = DriftConfig::preset("s2"), s3 = DriftConfig::preset("s3"),
                    s4 = DriftConfig::preset("s4");
  CHECK(s1.isZero());
  CHECK((s2.mu_xyz_mps == 0 && s2.sigma2_xyz_m2ps2 == 2e-2 && s2.mu_yaw_radps == 0 && s2.sigma2_yaw_rad2ps2 == 2e-2));
  CHECK(
      (s3.mu_xyz_mps == 0 && s3.sigma2_xyz_m2ps2 == 5e-2 && s3.mu_yaw_radps == 1e-3 && s3.sigma2_yaw_rad2ps2 == 5e-2));
  CHECK((s4.mu_xyz_mps == 0 && s4.sigma2_xyz_m2ps2 == 8e-2 && s4.mu_yaw_radps == 1.5e-3 &&
         s4.sigma2_yaw_rad2ps2 == 8e-2));
  CHECK(s3.rate_hz == 200.0);
  CHECK_THROWS_AS(DriftConfig::preset("s5"), std::invalid_argument);
  DriftConfig bad;
  bad.sigma2_xyz_m2ps2 = -1.0;
  CHECK_THROWS_WITH(bad.validate(), Catch::Contains("sigma2_xyz_m2ps2"));
}

TEST_CASE("s1 odometry equals the ground truth along a curved flight", "[sim][drift]") {
  DriftingOdometry odom(DriftConfig::preset("s1", 7), truthAt(0.0), 0.0);
  double max_p = 0.0, max_yaw = 0.0;
  // At the drift rate, then at an off-grid camera rate: both must follow the truth exactly.
  for (int k = 1; k <= 200 * 30; ++k) {
    const double t = k / 200.0;
    const FlatPose o = odom.advance(t, truthAt(t));
    max_p = std::max(max_p, (o.position_W - truthAt(t).position_W).norm());
    max_yaw = std::max(max_yaw, std::abs(angleDifference(o.yaw_rad, truthAt(t).yaw_rad)));
  }
  for (int k = 1; k <= 15 * 30; ++k) {
    const double t = 30.0 + k / 15.0;
    const FlatPose o = odom.advance(t, truthAt(t));
    max_p = std::max(max_p, (o.position_W - truthAt(t).position_W).norm());
    max_yaw = std::max(max_yaw, std::abs(angleDifference(o.yaw_rad, truthAt(t).yaw_rad)));
  }
  CHECK(odom.steps() == 200 * 60);
  CHECK(max_p < 1e-9);
  CHECK(max_yaw < 1e-9);
}

TEST_CASE("drift increments have the configured mean and variance", "[sim][drift]") {
  // n draws: the sample mean is within 5 standard errors sigma / sqrt(n) of mu, and the sample
  // variance within 5 standard errors sigma^2 sqrt(2 / (n - 1)) of sigma^2 (normal draws). With
  // the fixed seeds, a failure means the model is wrong, not bad luck (p ~ 6e-7 per check).
  const int n = 200000;
  for (const char* level : {"s2", "s3", "s4"}) {
    CAPTURE(level);
    const DriftConfig c = DriftConfig::preset(level, 42);
    DriftingOdometry odom(c, FlatPose{});
    std::array<double, 4> sum{}, sum2{};
    for (int i = 0; i < n; ++i) {
      const DriftIncrement d = odom.drawIncrement();
      const std::array<double, 4> x = {d.v_B_mps.x(), d.v_B_mps.y(), d.v_B_mps.z(), d.w_radps};
      for (int a = 0; a < 4; ++a) sum[a] += x[a], sum2[a] += x[a] * x[a];
    }
    for (int a = 0; a < 4; ++a) {
      CAPTURE(a);
      const double mu = a < 3 ? c.mu_xyz_mps : c.mu_yaw_radps;
      const double var = a < 3 ? c.sigma2_xyz_m2ps2 : c.sigma2_yaw_rad2ps2;
      const double mean = sum[a] / n;
      const double sample_var = (sum2[a] - n * mean * mean) / (n - 1);
      CHECK(std::abs(mean - mu) < 5.0 * std::sqrt(var / n));
      CHECK(std::abs(sample_var - var) < 5.0 * var * std::sqrt(2.0 / (n - 1)));
    }
  }
}

TEST_CASE("the velocity error acts in the body frame: a forward bias follows the believed heading", "[sim][drift]") {
  // The vehicle turns on the spot a quarter circle in 10 s. A constant velocity error of 0.1 m/s on
  // every body axis (no noise) then moves the odometry by the integral of Rz(yaw) (0.1, 0.1, 0.1).
  DriftConfig c;
  c.mu_xyz_mps = 0.1;
  DriftingOdometry odom(c, FlatPose{});
  const double T = 10.0, w = (M_PI / 2) / T;
  for (int k = 1; k <= 200 * 10; ++k) odom.advance(k / 200.0, FlatPose{Vec3d::Zero(), w * k / 200.0});
  // Left-endpoint sums of Rz(w t) (0.1, 0.1) dt, as the model applies the error at each step start.
  Vec3d expected = Vec3d::Zero();
  for (int k = 0; k < 2000; ++k)
    expected += Eigen::AngleAxisd(w * k / 200.0, Vec3d::UnitZ()) * Vec3d(0.1, 0.1, 0.1) / 200.0;
  CHECK((odom.pose().position_W - expected).norm() < 1e-9);
  // In the world frame the same error would have moved it by (1, 1, 1): clearly different.
  CHECK((odom.pose().position_W - Vec3d(1, 1, 1)).norm() > 0.3);
  CHECK(odom.pose().yaw_rad == Approx(M_PI / 2).margin(1e-9));
}

TEST_CASE("drift is seeded: the same seed replays the same odometry, another seed does not", "[sim][drift]") {
  auto run = [](std::uint64_t seed) {
    DriftingOdometry odom(DriftConfig::preset("s3", seed), truthAt(0.0));
    for (int k = 1; k <= 2000; ++k) odom.advance(k / 200.0, truthAt(k / 200.0));
    return odom.pose();
  };
  CHECK((run(3).position_W - run(3).position_W).norm() == 0.0);
  CHECK((run(3).position_W - run(4).position_W).norm() > 1e-4);
  DriftingOdometry odom(DriftConfig::preset("s2"), FlatPose{}, 1.0);
  CHECK_THROWS_AS(odom.advance(0.5, FlatPose{}), std::invalid_argument);
}

TEST_CASE("the drift declared to the planner is the random walk the odometry makes", "[sim][drift]") {
  // 400 vehicles at rest for 10 s at s3: the position error per axis and the yaw error spread as
  // odometryDriftOf's random walks times sqrt(10 s), within 5 standard errors of a sample
  // standard deviation (sigma / sqrt(2 n)).
  const DriftConfig c = DriftConfig::preset("s3", 1);
  const planner::OdometryDrift declared = odometryDriftOf(c);
  CHECK(declared.position_bias_m_per_s == c.mu_xyz_mps);
  CHECK(declared.yaw_bias_rad_per_s == c.mu_yaw_radps);
  const int n = 400;
  const double T = 10.0;
  double pos2 = 0.0, yaw_sum = 0.0, yaw2 = 0.0, lever2 = 0.0;
  for (int seed = 1; seed <= n; ++seed) {
    DriftConfig ci = c;
    ci.seed = std::uint64_t(seed);
    DriftingOdometry odom(ci, FlatPose{});
    const FlatPose p = odom.advance(T, FlatPose{});
    pos2 += p.position_W.squaredNorm();
    yaw_sum += p.yaw_rad;
    yaw2 += p.yaw_rad * p.yaw_rad;
    // Where the odometry puts a point 2 m ahead of the vehicle (facing +x).
    const Vec3d ahead = p.position_W + Eigen::AngleAxisd(p.yaw_rad, Vec3d::UnitZ()) * Vec3d(2.0, 0.0, 0.0);
    lever2 += (ahead - Vec3d(2.0, 0.0, 0.0)).squaredNorm();
  }
  const double pos_sd = std::sqrt(pos2 / (3.0 * n));  // pooled over the three axes
  const double yaw_mean = yaw_sum / n;
  const double yaw_sd = std::sqrt((yaw2 - n * yaw_mean * yaw_mean) / (n - 1));
  const double expected_pos_sd = declared.position_m_per_sqrt_s * std::sqrt(T);
  const double expected_yaw_sd = declared.yaw_rad_per_sqrt_s * std::sqrt(T);
  CHECK(std::abs(pos_sd - expected_pos_sd) < 5.0 * expected_pos_sd / std::sqrt(2.0 * 3 * n));
  CHECK(std::abs(yaw_sd - expected_yaw_sd) < 5.0 * expected_yaw_sd / std::sqrt(2.0 * n));
  // The planner's displacement adds the three errors (position walk, yaw walk, yaw bias): a bound.
  // The spread of the point 2 m ahead adds them in quadrature, so it lies between the bound /
  // sqrt(3) and the bound.
  const double rms_ahead = std::sqrt(lever2 / n);
  CHECK(rms_ahead < declared.displacement_m(T, 2.0));
  CHECK(rms_ahead > declared.displacement_m(T, 2.0) / std::sqrt(3.0));
  // s1 declares no drift at all.
  const planner::OdometryDrift none = odometryDriftOf(DriftConfig::preset("s1", 1));
  CHECK(none.displacement_m(600.0, 2.0) == 0.0);
}
