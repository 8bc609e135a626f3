// The 4-DOF alignment of an estimate with the truth (sim/trajectory_alignment.hpp).
#include <catch2/catch.hpp>

#include "vdbmap/sim/trajectory_alignment.hpp"

#include <cmath>
#include <limits>
#include <random>

using namespace vdbmap;
using namespace vdbmap::sim;

namespace {
/// Points spread over a house-sized box, seeded.
std::vector<Vec3d> scatter(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> x(-9.0, 9.0), y(-5.0, 5.0), z(0.3, 2.2);
  std::vector<Vec3d> p;
  for (std::size_t i = 0; i < n; ++i) p.emplace_back(x(rng), y(rng), z(rng));
  return p;
}
std::vector<Vec3d> moved(const FlatPose& T, const std::vector<Vec3d>& p) {
  std::vector<Vec3d> q;
  for (const Vec3d& v : p) q.push_back(applyAlignment(T, v));
  return q;
}
}  // namespace

TEST_CASE("alignYawTranslation recovers a known yaw and translation from noise-free points exactly",
          "[sim][alignment]") {
  const std::vector<Vec3d> from = scatter(200, 1);
  for (const FlatPose& T : {FlatPose{Vec3d(0.3, -0.2, 0.15), 3.0 * M_PI / 180.0}, FlatPose{Vec3d(-4.0, 2.5, -1.0), 2.8},
                            FlatPose{Vec3d::Zero(), 0.0}}) {
    const std::vector<Vec3d> to = moved(T, from);
    const FlatPose A = alignYawTranslation(from, to);
    CHECK(std::abs(angleDifference(A.yaw_rad, T.yaw_rad)) < 1e-12);
    CHECK((A.position_W - T.position_W).norm() < 1e-9);
    CHECK(alignedRmse(A, from, to) < 1e-9);
  }
}

TEST_CASE("alignYawTranslation with noisy points is the least-squares optimum a brute-force yaw search finds",
          "[sim][alignment]") {
  // Truth = the estimate moved by 2.5 deg and a few centimetres, plus 5 cm of noise per axis. For a
  // given yaw the best translation matches the centroids, so a fine search over yaw alone finds the
  // optimum; Umeyama's closed form must be at least as good, and agree with it.
  const std::vector<Vec3d> from = scatter(300, 7);
  const FlatPose T{Vec3d(0.08, -0.05, 0.12), 2.5 * M_PI / 180.0};
  std::vector<Vec3d> to = moved(T, from);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (Vec3d& v : to) v += Vec3d(noise(rng), noise(rng), noise(rng));

  const FlatPose A = alignYawTranslation(from, to);
  Vec3d from_mean = Vec3d::Zero(), to_mean = Vec3d::Zero();
  for (std::size_t i = 0; i < from.size(); ++i) from_mean += from[i], to_mean += to[i];
  from_mean /= double(from.size()), to_mean /= double(to.size());
  double best_rmse = std::numeric_limits<double>::infinity(), best_yaw = 0.0;
  for (double yaw = -0.2; yaw <= 0.2; yaw += 1e-5) {
    FlatPose B{Vec3d::Zero(), yaw};
    B.position_W = to_mean - applyAlignment(B, from_mean);
    const double rmse = alignedRmse(B, from, to);
    if (rmse < best_rmse) best_rmse = rmse, best_yaw = yaw;
  }
  CHECK(alignedRmse(A, from, to) <= best_rmse + 1e-12);
  CHECK(std::abs(A.yaw_rad - best_yaw) < 2e-5);
  // and it lands near the transform the points were moved by (noise 5 cm over 300 points)
  CHECK(std::abs(A.yaw_rad - T.yaw_rad) < 0.2 * M_PI / 180.0);
  CHECK((A.position_W - T.position_W).norm() < 0.02);
  CHECK(alignedRmse(A, from, to) < alignedRmse(FlatPose{}, from, to));
}

TEST_CASE("points at one x-y position give yaw 0 and the mean offset", "[sim][alignment]") {
  const std::vector<Vec3d> from = {Vec3d(1, 2, 0.5), Vec3d(1, 2, 1.5), Vec3d(1, 2, 1.0)};
  const std::vector<Vec3d> to = {Vec3d(1.2, 1.9, 0.6), Vec3d(1.2, 1.9, 1.6), Vec3d(1.2, 1.9, 1.1)};
  const FlatPose A = alignYawTranslation(from, to);
  CHECK(A.yaw_rad == 0.0);
  CHECK((A.position_W - Vec3d(0.2, -0.1, 0.1)).norm() < 1e-12);
}

TEST_CASE("alignYawTranslation refuses mismatched sizes fewer than two pairs and values that are not finite",
          "[sim][alignment]") {
  const std::vector<Vec3d> two = {Vec3d(0, 0, 0), Vec3d(1, 0, 0)};
  CHECK_THROWS_AS(alignYawTranslation(two, {Vec3d::Zero()}), std::invalid_argument);
  CHECK_THROWS_AS(alignYawTranslation({Vec3d::Zero()}, {Vec3d::Zero()}), std::invalid_argument);
  CHECK_THROWS_AS(alignYawTranslation(two, {Vec3d(0, 0, 0), Vec3d(std::nan(""), 0, 0)}), std::invalid_argument);
  CHECK_THROWS_AS(alignedRmse(FlatPose{}, two, {Vec3d::Zero()}), std::invalid_argument);
  CHECK(alignedRmse(FlatPose{}, {}, {}) == 0.0);
}
