// OdometryDrift: the displacement a declared odometry noise predicts, and the longest time it
// stays within a tolerance, against a brute-force scan of the displacement.
#include "vdbmap/planner/odometry_drift.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <random>

using namespace vdbmap::planner;

namespace {
/// Brute force of longestWithin: the last t on a grid of step_s in [min_s, max_s] within the tolerance.
double scanLongestWithin(const OdometryDrift& d, double tol, double lever, double min_s, double max_s, double step_s) {
  double best = min_s;
  for (double t = min_s; t <= max_s + 1e-12; t += step_s)
    if (d.displacement_m(t, lever) <= tol) best = t;
  return best;
}
}  // namespace

TEST_CASE("OdometryDrift::validate names the field", "[planner][safety]") {
  OdometryDrift d;
  CHECK_NOTHROW(d.validate());
  d.position_m_per_sqrt_s = -0.1;
  CHECK_THROWS_WITH(d.validate(), Catch::Contains("OdometryDrift.position_m_per_sqrt_s"));
  d = {};
  d.yaw_rad_per_sqrt_s = NAN;
  CHECK_THROWS_WITH(d.validate(), Catch::Contains("OdometryDrift.yaw_rad_per_sqrt_s"));
  d = {};
  d.yaw_bias_rad_per_s = 2.0;
  CHECK_THROWS_WITH(d.validate(), Catch::Contains("OdometryDrift.yaw_bias_rad_per_s"));
  d = {};
  d.position_bias_m_per_s = -11.0;
  CHECK_THROWS_WITH(d.validate(), Catch::Contains("OdometryDrift.position_bias_m_per_s"));
  CHECK_THROWS(d.displacement_m(-1.0, 1.0));
  CHECK_THROWS(OdometryDrift{}.longestWithin(0.2, 2.0, 10.0, 5.0));
}

TEST_CASE("The displacement is the position walk over three axes plus the arc of the yaw error", "[planner][safety]") {
  OdometryDrift d;
  d.position_m_per_sqrt_s = 0.01;
  d.yaw_rad_per_sqrt_s = 0.02;
  // Random walks grow with sqrt(t): 4 s doubles the 1 s displacement.
  CHECK(d.displacement_m(1.0, 2.0) == Approx(std::sqrt(3.0) * 0.01 + 2.0 * 0.02));
  CHECK(d.displacement_m(4.0, 2.0) == Approx(2.0 * d.displacement_m(1.0, 2.0)));
  CHECK(d.displacement_m(4.0, 0.0) == Approx(2.0 * std::sqrt(3.0) * 0.01));  // at the camera: position only
  // Biases grow with t, whatever their sign.
  d = {};
  d.yaw_bias_rad_per_s = -0.001;
  d.position_bias_m_per_s = 0.002;
  CHECK(d.displacement_m(10.0, 3.0) == Approx(std::sqrt(3.0) * 0.02 + 3.0 * 0.01));
  CHECK(OdometryDrift{}.displacement_m(100.0, 2.0) == 0.0);
}

TEST_CASE("The path term is the yaw drift integrated along the path, as a simulated walk gives it",
          "[planner][safety]") {
  // Brute force: a straight flight at v for T seconds with a yaw random walk (and no other
  // noise); the estimate's sideways error is the integral of the yaw error times v. Its standard
  // deviation over many flights is the path term's walk part, q v T sqrt(T / 3).
  OdometryDrift d;
  d.yaw_rad_per_sqrt_s = 0.0158;  // s3's
  const double v = 1.5, T = 6.0, dt = 0.005;
  std::mt19937 rng(7);
  std::normal_distribution<double> step(0.0, d.yaw_rad_per_sqrt_s * std::sqrt(dt));
  constexpr int kFlights = 4000;
  double sum_sq = 0.0;
  for (int k = 0; k < kFlights; ++k) {
    double yaw = 0.0, sideways = 0.0;
    for (double t = 0.0; t < T - 1e-9; t += dt) {
      yaw += step(rng);
      sideways += yaw * v * dt;
    }
    sum_sq += sideways * sideways;
  }
  const double simulated = std::sqrt(sum_sq / kFlights);
  const double path_term = d.displacement_m(T, 0.0, v * T) - d.displacement_m(T, 0.0);
  CHECK(path_term == Approx(simulated).epsilon(0.05));  // 4000 flights: about 1 % standard error
  // A yaw-rate bias b turns the path by b t: the sideways error is b v T^2 / 2 exactly.
  d = {};
  d.yaw_bias_rad_per_s = -0.001;
  CHECK(d.displacement_m(T, 2.0, v * T) - d.displacement_m(T, 2.0) == Approx(0.001 * v * T * T / 2.0));
  // No path, no term; a path never lowers the displacement; misuse throws.
  CHECK(d.displacement_m(T, 2.0, 0.0) == d.displacement_m(T, 2.0));
  CHECK(d.displacement_m(T, 2.0, 1.0) <= d.displacement_m(T, 2.0, 5.0));
  CHECK_THROWS(d.displacement_m(T, 2.0, -1.0));
  CHECK_THROWS(d.displacement_m(T, 2.0, std::numeric_limits<double>::quiet_NaN()));
}

TEST_CASE("The axis displacement is one axis' position walk and bias, without the yaw's arc", "[planner][safety]") {
  OdometryDrift d;
  d.position_m_per_sqrt_s = 0.01;
  d.position_bias_m_per_s = -0.002;
  d.yaw_rad_per_sqrt_s = 0.5;  // turns the camera, does not lift it
  d.yaw_bias_rad_per_s = 0.01;
  CHECK(d.axisDisplacement_m(0.0) == 0.0);
  CHECK(d.axisDisplacement_m(25.0) == Approx(0.01 * 5.0 + 0.002 * 25.0));
  // One axis of the three-axis walk that displacement_m counts at the camera.
  d.yaw_rad_per_sqrt_s = d.yaw_bias_rad_per_s = 0.0;
  CHECK(d.axisDisplacement_m(9.0) == Approx(d.displacement_m(9.0, 0.0) / std::sqrt(3.0)));
  CHECK_THROWS(d.axisDisplacement_m(-1.0));
  CHECK_THROWS(d.axisDisplacement_m(std::numeric_limits<double>::infinity()));
}

TEST_CASE("longestWithin equals a brute-force scan, and is clamped to [min_s, max_s]", "[planner][safety]") {
  // No drift: the longest window. Drift already too large at min_s: the shortest.
  CHECK(OdometryDrift{}.longestWithin(0.2, 2.0, 10.0, 60.0) == 60.0);
  OdometryDrift strong;
  strong.position_m_per_sqrt_s = 0.1;
  CHECK(strong.longestWithin(0.2, 2.0, 10.0, 60.0) == 10.0);
  CHECK(strong.longestWithin(0.0, 2.0, 0.0, 60.0) == 0.0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> walk(0.0, 0.03), bias(-0.004, 0.004), tol(0.05, 0.4), lever(0.0, 4.0);
  for (int i = 0; i < 200; ++i) {
    OdometryDrift d;
    d.position_m_per_sqrt_s = walk(rng);
    d.yaw_rad_per_sqrt_s = walk(rng);
    d.position_bias_m_per_s = i % 3 == 0 ? bias(rng) : 0.0;
    d.yaw_bias_rad_per_s = i % 2 == 0 ? bias(rng) : 0.0;
    const double t = tol(rng), l = lever(rng);
    const double step_s = 0.01;
    const double got = d.longestWithin(t, l, 1.0, 120.0);
    INFO("case " << i);
    CHECK(got >= 1.0);
    CHECK(got <= 120.0);
    CHECK(std::abs(got - scanLongestWithin(d, t, l, 1.0, 120.0, step_s)) <= step_s);
    if (got > 1.0 && got < 120.0) CHECK(d.displacement_m(got, l) == Approx(t).epsilon(1e-9));
  }
}
