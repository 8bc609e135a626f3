// Hit counting of depth rows: the two- and four-pixel kernels against the one-pixel reference,
// run for run, on every kind of depth and for every placement the integrator counts with.
#include "internal/hit_counter.hpp"

#include <catch2/catch.hpp>

#include <limits>
#include <random>
#include <vector>

using namespace vdbmap;
using internal::HitPose;
using internal::HitRun;
using internal::SimdLevel;

namespace {

/// Depths around and between the range limits, on voxel faces' scale, and invalid ones.
float randomDepth(std::mt19937& rng, const IntegratorConfig& in) {
  auto uniform = [&](double lo, double hi) { return float(std::uniform_real_distribution<double>(lo, hi)(rng)); };
  switch (std::uniform_int_distribution<int>(0, 9)(rng)) {
    case 0: return std::numeric_limits<float>::quiet_NaN();
    case 1:
      return std::uniform_int_distribution<int>(0, 1)(rng) ? std::numeric_limits<float>::infinity()
                                                           : -std::numeric_limits<float>::infinity();
    case 2: return std::uniform_int_distribution<int>(0, 1)(rng) ? 0.0f : -uniform(0.0, 2.0);
    case 3: return uniform(0.0, in.min_range_m);  // too close
    case 4: return float(in.min_range_m);
    case 5: return float(in.max_range_m);
    case 6: return uniform(in.max_range_m, 2.0 * in.max_range_m);  // beyond
    default: return uniform(in.min_range_m, in.max_range_m);
  }
}

HitPose randomPose(std::mt19937& rng, std::int64_t sign) {
  std::uniform_real_distribution<double> angle(-3.1, 3.1), offset(-20.0, 20.0);
  const Eigen::Matrix3d R =
      (Eigen::AngleAxisd(angle(rng), Vec3d::UnitZ()) * Eigen::AngleAxisd(angle(rng) / 3.0, Vec3d::UnitY()) *
       Eigen::AngleAxisd(angle(rng) / 3.0, Vec3d::UnitX()))
          .toRotationMatrix();
  return {R, Vec3d(offset(rng), offset(rng), offset(rng)), sign};
}

bool sameRuns(const std::vector<HitRun>& a, const std::vector<HitRun>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].key != b[i].key || a[i].count != b[i].count) return false;
  return true;
}

}  // namespace

TEST_CASE("every hit-row kernel counts the same runs as the one-pixel reference", "[hits][pixels]") {
  std::vector<SimdLevel> kernels{SimdLevel::Sse2};
  if (internal::simdLevel() == SimdLevel::Avx2)
    kernels.push_back(SimdLevel::Avx2);
  else
    WARN("this CPU has no AVX2: the four-pixel kernel is not compared");
  TsdfConfig tsdf;
  tsdf.voxel_size_m = 0.02;
  IntegratorConfig in;
  in.min_range_m = 0.4;
  in.max_range_m = 4.0;
  const internal::EndVoxels ends(tsdf, in);
  std::mt19937 rng(20261128);
  // One placement (integration, de-integration), a move (opposite signs: points that stay are
  // skipped) and two of the same sign.
  const std::vector<std::vector<std::int64_t>> placements{{1}, {-1}, {-1, 1}, {1, 1}};
  std::size_t surface_points = 0, skipped_moves = 0;
  for (const int width : {1, 2, 3, 4, 5, 7, 8, 9, 641}) {
    const CameraIntrinsics K{width, 9, 500.0, 500.0, 0.5 * width - 0.3, 4.1};
    DepthImage depth(width, 9);
    for (float& z : depth.depth_m) z = randomDepth(rng, in);
    // Smooth rows too (a slanted plane, a few pixels per voxel), whose points form long runs.
    for (int v = 0; v < 4; ++v)
      for (int u = 0; u < width; ++u) depth.at(u, v) = 1.5f + 0.0007f * float(u) + 0.01f * float(v);
    for (const std::vector<std::int64_t>& signs : placements) {
      std::vector<HitPose> poses;
      for (const std::int64_t s : signs) poses.push_back(randomPose(rng, s));
      if (signs.size() == 2 && signs[0] == -signs[1] && width == 641) {
        // A small move, so that most points stay in their voxel.
        poses[1] = poses[0];
        poses[1].sign = signs[1];
        poses[1].t += Vec3d(0.004, -0.003, 0.002);
      }
      for (int v = 0; v < depth.height; ++v) {
        std::vector<std::vector<HitRun>> expected(poses.size());
        internal::countRowHits(depth, v, K, ends, poses, expected.data(), SimdLevel::Scalar);
        for (const SimdLevel kernel : kernels) {
          std::vector<std::vector<HitRun>> runs(poses.size());
          internal::countRowHits(depth, v, K, ends, poses, runs.data(), kernel);
          INFO("width " << width << ", row " << v << ", poses " << poses.size() << ", kernel " << int(kernel));
          for (std::size_t j = 0; j < poses.size(); ++j) CHECK(sameRuns(runs[j], expected[j]));
        }
        for (const HitRun& r : expected[0]) surface_points += std::size_t(std::abs(r.count));
        if (signs.size() == 2 && signs[0] == -signs[1] && width == 641) {
          std::size_t moved = 0;
          for (const HitRun& r : expected[0]) moved += std::size_t(std::abs(r.count));
          skipped_moves += std::size_t(width) - moved;
        }
      }
    }
  }
  CHECK(surface_points > 5000);  // the rows are not all invalid
  CHECK(skipped_moves > 1000);   // the small move left points in their voxel
}
