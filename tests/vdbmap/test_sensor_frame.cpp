// SensorFrame: the one frame type from a frame source through the mapper to the volume.
#include "vdbmap/keyframe_store.hpp"
#include "vdbmap/mapper.hpp"
#include "vdbmap/sensor_frame.hpp"
#include "vdbmap/testing/analytic_scene.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <catch2/catch.hpp>

using namespace vdbmap;

namespace {

std::shared_ptr<const CameraIntrinsics> smallCamera() {
  return std::make_shared<const CameraIntrinsics>(CameraIntrinsics{160, 120, 96.8, 96.8, 80.0, 60.0});
}

TsdfConfig tsdf() {
  TsdfConfig c;
  c.voxel_size_m = 0.1;
  return c;
}

}  // namespace

TEST_CASE("a sensor frame is a depth image with its camera or points, and says which", "[sensor_frame]") {
  const auto K = smallCamera();
  const SensorFrame depth = SensorFrame::depth(DepthImage(K->width, K->height, 2.0f), K);
  CHECK(depth.isDepth());
  CHECK(depth.depthImage().at(3, 4) == 2.0f);
  CHECK(&depth.intrinsics() == K.get());  // frames of one sensor share its camera
  CHECK_THROWS_AS(depth.points_S(), std::logic_error);

  const SensorFrame points = SensorFrame::points({Vec3f(1, 2, 3)});
  CHECK_FALSE(points.isDepth());
  CHECK(points.points_S().size() == 1);
  CHECK(points.sharedIntrinsics() == nullptr);
  CHECK_THROWS_AS(points.depthImage(), std::logic_error);
  CHECK_THROWS_AS(points.intrinsics(), std::logic_error);

  // A depth image needs its camera, of its size.
  CHECK_THROWS_WITH(SensorFrame::depth(DepthImage(K->width, K->height), nullptr), Catch::Contains("intrinsics"));
  CHECK_THROWS_WITH(SensorFrame::depth(DepthImage(K->width + 1, K->height), K),
                    Catch::Contains("161x120") && Catch::Contains("160x120"));
}

TEST_CASE("the keyframe store encodes a sensor frame and decodes it as its typed decoders do",
          "[sensor_frame][keyframes]") {
  const auto K = smallCamera();
  const testing::AnalyticScene scene = testing::AnalyticScene::demoRoom();
  const Pose3d T = lookingPose({0.5, 0.2, 1.2}, 0.7, 0.2);
  const DepthImage depth = scene.renderDepth(*K, T, 5.0);

  const SensorFrame d = EncodedFrame::encode(SensorFrame::depth(depth, K), 0.001).decodeFrame();
  REQUIRE(d.isDepth());
  CHECK(d.depthImage().depth_m == EncodedFrame::fromDepth(depth, K, 0.001).decodeDepth().depth_m);
  CHECK(d.sharedIntrinsics() == K);

  const PointCloud points_S = backProject(depth, *K, 4);
  const SensorFrame p = EncodedFrame::encode(SensorFrame::points(points_S), 0.001).decodeFrame();
  REQUIRE_FALSE(p.isDepth());
  const PointCloud typed = EncodedFrame::fromPoints(points_S, 0.001).decode();
  REQUIRE(p.points_S().size() == typed.size());
  for (std::size_t i = 0; i < typed.size(); ++i)
    REQUIRE(((p.points_S()[i].array() == typed[i].array()).all() ||
             (!typed[i].allFinite() && !p.points_S()[i].allFinite())));
}

TEST_CASE("a frame encoded raw and compressed later equals one encoded compressed", "[sensor_frame][keyframes]") {
  const auto K = smallCamera();
  const testing::AnalyticScene scene = testing::AnalyticScene::demoRoom();
  const DepthImage depth = scene.renderDepth(*K, lookingPose({0.5, 0.2, 1.2}, 0.7, 0.2), 5.0);
  for (const SensorFrame& frame : {SensorFrame::depth(depth, K), SensorFrame::points(backProject(depth, *K, 3))}) {
    const EncodedFrame raw = EncodedFrame::encode(frame, 0.001, false);
    const EncodedFrame direct = EncodedFrame::encode(frame, 0.001, true);
    const EncodedFrame later = raw.compressed();
    CHECK_FALSE(raw.isCompressed());
    CHECK(later.isCompressed());
    CHECK(later.bytes() == direct.bytes());
    CHECK(later.bytes() < raw.bytes());
    // The same points from all three (NaN marks invalid points in a cloud).
    const PointCloud a = raw.decode(), b = later.decode(), c = direct.decode();
    REQUIRE(a.size() == c.size());
    REQUIRE(b.size() == c.size());
    for (std::size_t i = 0; i < c.size(); ++i) {
      const bool valid = c[i].allFinite();
      REQUIRE(a[i].allFinite() == valid);
      REQUIRE(b[i].allFinite() == valid);
      if (valid) REQUIRE(((a[i].array() == c[i].array()).all() && (b[i].array() == c[i].array()).all()));
    }
    CHECK(later.compressed().bytes() == later.bytes());  // already compressed: a copy
  }
}

TEST_CASE("the volume integrates a sensor frame bit-identically to the typed calls, and undoes it exactly",
          "[sensor_frame][tsdf]") {
  const auto K = smallCamera();
  const testing::AnalyticScene scene = testing::AnalyticScene::demoRoom();
  const Pose3d T0 = lookingPose({0.5, 0.2, 1.2}, 0.7, 0.2), T1 = lookingPose({0.7, 0.1, 1.2}, 0.9, 0.2);
  const DepthImage depth = scene.renderDepth(*K, T0, 5.0);
  const PointCloud points_S = backProject(scene.renderDepth(*K, T1, 5.0), *K, 3);

  for (const RayMode mode : {RayMode::Projective, RayMode::Merged}) {
    INFO("ray mode " << toString(mode));
    IntegratorConfig ic;
    ic.ray_mode = mode;
    TsdfVolume typed(tsdf(), ic), general(tsdf(), ic), empty(tsdf(), ic);
    VoxelFootprint typed_fp, general_fp;
    typed.integrate(1, depth, *K, T0, &typed_fp);
    typed.integrate(2, points_S, T1);
    general.integrate(1, SensorFrame::depth(depth, K), T0, &general_fp);
    general.integrate(2, SensorFrame::points(points_S), T1, &general_fp);  // points leave no footprint
    CHECK(general.exactlyEquals(typed));
    CHECK(general_fp.empty());

    typed.reintegrate(1, depth, *K, T0, T1);
    general.reintegrate(1, SensorFrame::depth(depth, K), T0, T1);
    CHECK(general.exactlyEquals(typed));

    general.deintegrate(1, SensorFrame::depth(depth, K), T1);
    general.deintegrate(2, SensorFrame::points(points_S), T1);
    CHECK(general.exactlyEquals(empty));
  }
}

TEST_CASE("Mapper::addFrame integrates what the store decodes, as the volume would from the decoded frame",
          "[sensor_frame][mapper]") {
  const auto K = smallCamera();
  const testing::AnalyticScene scene = testing::AnalyticScene::demoRoom();
  MapperConfig c;
  c.tsdf = tsdf();
  c.mode = ConsistencyMode::All;
  Mapper mapper(c);
  TsdfVolume reference(c.tsdf, c.integrator);
  const std::vector<Pose3d> poses = testing::AnalyticScene::demoTrajectory(4);
  for (FrameId id = 0; id < 4; ++id) {
    const Pose3d& T = poses[id];
    const SensorFrame frame = SensorFrame::depth(scene.renderDepth(*K, T, 5.0), K);
    mapper.addFrame(id, 0.1 * double(id), frame, T);
    reference.integrate(id, EncodedFrame::encode(frame, c.depth_unit_m).decodeFrame(), T);
  }
  CHECK(mapper.volume().exactlyEquals(reference));
  CHECK(mapper.keyframesKept() == 4);
  // The newest frame is compressed off the caller's thread; a reader of the store sees every
  // frame compressed, as a save writes it.
  for (const auto& [id, kf] : mapper.keyframes()) CHECK(kf.data.isCompressed());
}

TEST_CASE("the deprecated addDepthFrame and addPointFrame still integrate as addFrame does", "[sensor_frame][mapper]") {
  const auto K = smallCamera();
  const testing::AnalyticScene scene = testing::AnalyticScene::demoRoom();
  const std::vector<Pose3d> poses = testing::AnalyticScene::demoTrajectory(2);
  const DepthImage depth = scene.renderDepth(*K, poses[0], 5.0);
  const PointCloud points_S = backProject(scene.renderDepth(*K, poses[1], 5.0), *K, 3);
  MapperConfig c;
  c.tsdf = tsdf();
  Mapper now(c), before(c);
  now.addFrame(0, 0.0, SensorFrame::depth(depth, K), poses[0]);
  now.addFrame(1, 0.1, SensorFrame::points(points_S), poses[1]);
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
  before.addDepthFrame(0, 0.0, depth, K, poses[0]);
  before.addPointFrame(1, 0.1, points_S, poses[1]);
#pragma GCC diagnostic pop
  CHECK(now.volume().exactlyEquals(before.volume()));
}
