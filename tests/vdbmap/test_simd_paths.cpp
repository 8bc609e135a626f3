// The kernels' vector paths (internal/simd.hpp) against the narrower ones: integrating,
// re-integrating and de-integrating depth images gives the same map, hit counts and footprints bit
// for bit at every SIMD level this CPU runs.
#include "internal/simd.hpp"
#include "tsdf_test_helpers.hpp"
#include "common/shared_data.hpp"
#include "vdbmap/io/frame_source.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <tuple>

using namespace vdbmap;
using namespace vdbmap::test;
using internal::SimdLevel;

namespace {

struct Frame {
  DepthImage depth;
  CameraIntrinsics K;
  Pose3d T_W_S;
};

/// What a run leaves: the volume and every footprint it was given, leaves sorted.
struct Run {
  TsdfVolume volume;
  std::vector<VoxelFootprint> footprints;
};

void sortLeaves(VoxelFootprint& f) {
  std::sort(f.begin(), f.end(), [](const LeafFootprint& a, const LeafFootprint& b) { return a.origin < b.origin; });
}

/// Integrates every frame, moves every frame by `correction`, then de-integrates every other
/// frame, at the given SIMD cap.
Run integrateAt(SimdLevel cap, const std::vector<Frame>& frames, const Pose3d& correction, const TsdfConfig& tsdf,
                const IntegratorConfig& in) {
  const internal::ScopedSimdCap scoped(cap);
  Run run{TsdfVolume(tsdf, in), {}};
  for (std::size_t i = 0; i < frames.size(); ++i) {
    run.footprints.emplace_back();
    run.volume.integrate(i, frames[i].depth, frames[i].K, frames[i].T_W_S, &run.footprints.back());
  }
  for (std::size_t i = 0; i < frames.size(); ++i) {
    run.footprints.emplace_back();
    run.volume.reintegrate(i, frames[i].depth, frames[i].K, frames[i].T_W_S, correction * frames[i].T_W_S,
                           &run.footprints.back());
  }
  for (std::size_t i = 0; i < frames.size(); i += 2)
    run.volume.deintegrate(i, frames[i].depth, frames[i].K, correction * frames[i].T_W_S);
  for (VoxelFootprint& f : run.footprints) sortLeaves(f);
  return run;
}

bool sameFootprints(const std::vector<VoxelFootprint>& a, const std::vector<VoxelFootprint>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].size() != b[i].size()) return false;
    for (std::size_t l = 0; l < a[i].size(); ++l)
      if (a[i][l].origin != b[i][l].origin || a[i][l].voxels != b[i][l].voxels) return false;
  }
  return true;
}

/// Compares every level this CPU runs with the widest, on `frames`.
void compareLevels(const std::vector<Frame>& frames, const Pose3d& correction, const TsdfConfig& tsdf,
                   const IntegratorConfig& in) {
  const SimdLevel widest = internal::simdLevel();
  if (widest != SimdLevel::Avx2) WARN("this CPU has no AVX2: only the narrower paths are compared");
  const Run reference = integrateAt(widest, frames, correction, tsdf, in);
  REQUIRE(reference.volume.activeVoxelCount() > 1000);
  REQUIRE(reference.volume.hitCountGrid()->activeVoxelCount() > 100);
  for (const SimdLevel cap : {SimdLevel::Scalar, SimdLevel::Sse2}) {
    if (cap >= widest) continue;
    INFO("capped at level " << int(cap) << " against level " << int(widest));
    const Run run = integrateAt(cap, frames, correction, tsdf, in);
    CHECK(run.volume.exactlyEquals(reference.volume));
    CHECK(sameHitCounts(run.volume, reference.volume));
    CHECK(sameFootprints(run.footprints, reference.footprints));
  }
}

}  // namespace

TEST_CASE("every SIMD level integrates, moves and removes analytic images bit for bit alike",
          "[tsdf][projective][simd]") {
  const auto poses = randomPoses(6, 52);
  const auto images = randomDepthImages(poses, 53);
  std::vector<Frame> frames;
  for (std::size_t i = 0; i < poses.size(); ++i) frames.push_back({images[i], smallCamera(), poses[i]});
  const Pose3d correction =
      Eigen::Translation3d(0.021, -0.013, 0.008) * Eigen::AngleAxisd(0.011, Vec3d::UnitZ()) * Pose3d::Identity();
  struct Case {
    const char* name;
    double voxel_m, truncation_vox, max_range_m;
    Weighting weighting;
  };
  for (const Case& c : {Case{"5 cm, far pixels only carve", 0.05, 3.0, 4.0, Weighting::InverseSquare},
                        Case{"2 cm, constant weights", 0.02, 3.0, 10.0, Weighting::Constant},
                        Case{"10 cm, wide band", 0.1, 8.0, 6.0, Weighting::InverseSquare}}) {
    INFO(c.name);
    TsdfConfig tsdf = config(c.voxel_m, c.weighting);
    tsdf.truncation_vox = c.truncation_vox;
    IntegratorConfig in;
    in.ray_mode = RayMode::Projective;
    in.max_range_m = c.max_range_m;
    compareLevels(frames, correction, tsdf, in);
  }
}

TEST_CASE("every SIMD level integrates, moves and removes real Kinect frames bit for bit alike",
          "[tsdf][projective][simd][shared]") {
  const auto source = io::openDataset(requireSharedData("7scenes_redkitchen_tsdf_fusion_python"));
  std::vector<Frame> frames;
  for (std::size_t i = 0; i < 500; i += 50) {
    const io::Frame f = source->load(i);
    frames.push_back({f.data.depthImage(), f.data.intrinsics(), f.T_W_S});
  }
  const Pose3d correction =
      Eigen::Translation3d(0.031, -0.017, 0.009) * Eigen::AngleAxisd(0.013, Vec3d::UnitZ()) * Pose3d::Identity();
  IntegratorConfig in;
  in.ray_mode = RayMode::Projective;
  compareLevels(frames, correction, config(0.05), in);
}
