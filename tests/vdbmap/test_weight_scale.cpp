// The fixed-point weight scale: chosen from the max range so that far rays keep their weight, kept
// by a map through save and load, and checked in the files.
#include "common/fresh_dir.hpp"
#include "tsdf_test_helpers.hpp"
#include "vdbmap/file_error.hpp"
#include "vdbmap/map_file.hpp"
#include "vdbmap/tsdf_volume.hpp"
#include "vdbmap/voxel_codec.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

using namespace vdbmap;
using namespace vdbmap::test;

namespace {

IntegratorConfig maxRange(double max_range_m) {
  IntegratorConfig in;
  in.max_range_m = max_range_m;
  return in;
}

/// A camera of 0.5 degrees, so that a wall 60 m away spans a few voxels and the test stays small.
CameraIntrinsics narrowCamera() {
  CameraIntrinsics K;
  K.width = K.height = 8;
  K.fx = K.fy = 1000.0;
  K.cx = K.cy = 3.5;
  return K;
}

/// Frames of a wall ahead along world +x, from slightly shifted poses.
constexpr int kFrames = 8;
Pose3d framePose(int i) { return lookingPose({0.0, 0.01 * i, 0.0}, 0.0); }

}  // namespace

TEST_CASE("the weight scale is the smallest 1024 * 4^k giving a ray at max range 40 units, up to 2^20",
          "[tsdf][weight-scale]") {
  const TsdfConfig inverse_square;
  CHECK(weightScaleFor(inverse_square, maxRange(5.0)) == 1024);  // the default range keeps the old scale
  CHECK(weightScaleFor(inverse_square, maxRange(5.05)) == 1024);
  CHECK(weightScaleFor(inverse_square, maxRange(5.07)) == 4096);
  CHECK(weightScaleFor(inverse_square, maxRange(50.0)) == 262144);
  CHECK(weightScaleFor(inverse_square, maxRange(100.0)) == 1048576);
  CHECK(weightScaleFor(inverse_square, maxRange(1000.0)) == 1048576);
  for (double r = 0.25; r <= 161.9; r *= 1.1) {
    const std::int64_t s = weightScaleFor(inverse_square, maxRange(r));
    INFO("max range " << r << " m, scale " << s);
    CHECK(double(s) / (r * r) >= double(kMinUnitsAtMaxRange));
    CHECK((s == kMinWeightScale || double(s / 4) / (r * r) < double(kMinUnitsAtMaxRange)));
  }
  // Even at the largest range allowed, a ray keeps at least one unit.
  CHECK(std::llround(double(weightScaleFor(inverse_square, maxRange(1000.0))) / (1000.0 * 1000.0)) >= 1);

  CHECK(weightScaleFor(config(0.1, Weighting::Constant), maxRange(500.0)) == 1024);
  TsdfConfig fixed;
  fixed.weight_scale = 65536;
  CHECK(weightScaleFor(fixed, maxRange(5.0)) == 65536);
  CHECK(TsdfVolume(fixed, maxRange(100.0)).config().weight_scale == 65536);
  CHECK(TsdfVolume(inverse_square, maxRange(100.0)).config().weight_scale == 1048576);

  for (std::int64_t bad : {std::int64_t(-1024), std::int64_t(512), std::int64_t(3000), std::int64_t(1) << 21}) {
    TsdfConfig c;
    c.weight_scale = bad;
    CHECK_THROWS_WITH(c.validate(), Catch::Contains("TsdfConfig.weight_scale") && Catch::Contains("powers of two"));
  }
  CHECK_THROWS_WITH(VoxelCodec(TsdfConfig{}), Catch::Contains("weight_scale"));
}

TEST_CASE(
    "a wall 80 m away is carved to and added as surface, each ray weighing 1/z^2 within 1.25 %, and "
    "de-integrated exactly",
    "[tsdf][weight-scale][range]") {
  const Vec3d wall_W(80.0, 0.0, 0.0), halfway_W(40.0, 0.0, 0.0);
  const DepthImage depth(8, 8, 80.0f);
  const double per_frame = 1.0 / (80.0 * 80.0);
  for (const bool projective : {true, false}) {
    INFO((projective ? "depth image, projective" : "points, merged rays"));
    TsdfVolume volume(config(0.2), maxRange(100.0));
    for (int i = 0; i < kFrames; ++i) {
      const IntegrationStats stats = projective ? volume.integrate(i, depth, narrowCamera(), framePose(i))
                                                : volume.integrate(i, backProject(depth, narrowCamera()), framePose(i));
      CHECK(stats.points_beyond_range == 0);
    }
    const VoxelSample surface = volume.sample(volume.worldToVoxel(wall_W));
    CHECK(surface.state == VoxelState::Occupied);
    CHECK(surface.hits > 0);
    const VoxelSample free = volume.sample(volume.worldToVoxel(halfway_W));
    CHECK(free.state == VoxelState::Free);
    if (projective) {  // one update per voxel and frame (merged rays cross a voxel more than once)
      CHECK(std::abs(surface.weight / (kFrames * per_frame) - 1.0) <= 1.0 / 80.0);
      CHECK(std::abs(free.weight / (kFrames * per_frame) - 1.0) <= 1.0 / 80.0);
    }
    // De-integration stays exact at this scale.
    for (int i = 0; i < kFrames; ++i) {
      if (projective)
        volume.deintegrate(i, depth, narrowCamera(), framePose(i));
      else
        volume.deintegrate(i, backProject(depth, narrowCamera()), framePose(i));
    }
    CHECK(volume.activeVoxelCount() == 0);
  }
  SECTION("at a scale set too small for the range (1024, the old fixed one) such rays weigh 0: counted as invalid") {
    TsdfConfig old_scale = config(0.2);
    old_scale.weight_scale = 1024;
    for (const bool projective : {true, false}) {
      TsdfVolume volume(old_scale, maxRange(100.0));
      const IntegrationStats stats = projective ? volume.integrate(0, depth, narrowCamera(), framePose(0))
                                                : volume.integrate(0, backProject(depth, narrowCamera()), framePose(0));
      CHECK(stats.points_invalid == 64);
      CHECK(volume.sample(volume.worldToVoxel(halfway_W)).state == VoxelState::Unknown);
      CHECK(volume.sample(volume.worldToVoxel(halfway_W)).weight == 0.0f);
    }
  }
}

TEST_CASE("a map keeps its weight scale through save and load and integrates on bit for bit",
          "[tsdf][weight-scale][io]") {
  const DepthImage depth(8, 8, 15.0f);
  const auto dir = freshDir("vdbmap_test_weight_scale");
  for (const std::int64_t chosen : {std::int64_t(0), std::int64_t(1024)}) {
    // 0: the scale the range gives (16384 for 20 m); 1024: what every map was saved with before
    // the scale followed the range, which a load must honour, not choose again.
    TsdfConfig c = config(0.1);
    c.weight_scale = chosen;
    TsdfVolume volume(c, maxRange(20.0));
    const std::int64_t expected = chosen == 0 ? 16384 : 1024;
    REQUIRE(volume.config().weight_scale == expected);
    volume.integrate(0, depth, narrowCamera(), framePose(0));
    const auto path = dir / ("map_" + std::to_string(expected) + ".vdb");
    volume.save(path);
    CHECK(inspectMapFile(path).weight_scale == expected);

    TsdfVolume loaded = TsdfVolume::load(path);
    CHECK(loaded.config().weight_scale == expected);
    REQUIRE(loaded.exactlyEquals(volume));
    loaded.integrate(1, depth, narrowCamera(), framePose(1));
    volume.integrate(1, depth, narrowCamera(), framePose(1));
    CHECK(loaded.exactlyEquals(volume));
    loaded.deintegrate(0, depth, narrowCamera(), framePose(0));
    loaded.deintegrate(1, depth, narrowCamera(), framePose(1));
    CHECK(loaded.activeVoxelCount() == 0);
  }
}

TEST_CASE("a companion whose weight scale is not a valid scale is refused, naming it and the field",
          "[tsdf][weight-scale][io][bad-input]") {
  const auto dir = freshDir("vdbmap_test_weight_scale_bad");
  const auto path = dir / "map.vdb";
  TsdfVolume volume(config(0.1), maxRange(20.0));
  volume.integrate(0, DepthImage(8, 8, 15.0f), narrowCamera(), framePose(0));
  volume.save(path);
  const auto exact = TsdfVolume::exactStatePath(path);
  rewriteVdbFile(exact, exact, {}, [](openvdb::MetaMap& meta) {
    meta.removeMeta("weight_scale");
    meta.insertMeta("weight_scale", openvdb::Int64Metadata(3000));
  });
  CHECK_THROWS_WITH(TsdfVolume::load(path),
                    Catch::Contains(exact.string()) && Catch::Contains("weight_scale") && Catch::Contains("3000"));
  const MapFileInfo info = inspectMapFile(path);
  CHECK_FALSE(info.has_exact_state);
  CHECK(info.exact_state_problem.find("weight_scale") != std::string::npos);
}
