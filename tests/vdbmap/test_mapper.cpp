// The mapper's consistency modes and budgeted re-integration.
#include "vdbmap/mapper.hpp"
#include "vdbmap/mesh.hpp"
#include "vdbmap/testing/analytic_scene.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

using namespace vdbmap;
using testing::AnalyticScene;

namespace {
std::shared_ptr<const CameraIntrinsics> smallCamera() {
  auto K = std::make_shared<CameraIntrinsics>();
  K->width = 160;
  K->height = 120;
  K->fx = K->fy = 96.8;
  K->cx = 79.5;
  K->cy = 59.5;
  return K;
}

MapperConfig config(ConsistencyMode mode) {
  MapperConfig c;
  c.mode = mode;
  c.tsdf.voxel_size_m = 0.1;
  return c;
}

Pose3d moved(const Pose3d& T, const Vec3d& dt, double dyaw) {
  Pose3d out = T;
  out.translation() += dt;
  out.linear() = Eigen::AngleAxisd(dyaw, Vec3d::UnitZ()).toRotationMatrix() * T.linear();
  return out;
}

/// Root mean square distance of the mesh's vertices to the analytic surfaces.
double meshRmse(const TriangleMesh& mesh, const AnalyticScene& scene) {
  double sum = 0.0;
  for (const Vec3f& v : mesh.vertices) sum += std::pow(scene.distance(v.cast<double>()), 2);
  return std::sqrt(sum / std::max<double>(1.0, double(mesh.vertices.size())));
}

const AnalyticScene kScene = AnalyticScene::demoRoom();
}  // namespace

TEST_CASE("re-integrating a frame at pose B equals integrating it at B in a fresh map", "[mapper][reintegration]") {
  const auto K = smallCamera();
  const Pose3d A = lookingPose({0.5, 0.2, 1.2}, 0.3, 0.2);
  const Pose3d B = moved(A, {0.15, -0.1, 0.05}, 0.08);
  const DepthImage depth = kScene.renderDepth(*K, A, 5.0);
  for (const ConsistencyMode mode : {ConsistencyMode::All, ConsistencyMode::Keyframes}) {
    INFO("mode " << toString(mode));
    Mapper mapper(config(mode));
    mapper.addFrame(0, 0.0, SensorFrame::depth(depth, K), A);
    REQUIRE(mapper.updatePoses({{0, B}}) == 1);
    mapper.reintegrateAll(B.translation());
    Mapper fresh(config(mode));
    fresh.addFrame(0, 0.0, SensorFrame::depth(depth, K), B);
    CHECK(mapper.volume().exactlyEquals(fresh.volume()));
    CHECK(mapper.stats().reintegrated_frames == 1);
    CHECK(mapper.keyframes().at(0).T_W_S_integrated.isApprox(B));
  }
}

TEST_CASE("a frame corrected twice ends identical to integrating it once at the final pose", "[mapper][reintegration]") {
  const auto K = smallCamera();
  const Pose3d A = lookingPose({-0.5, 0.4, 1.0}, 2.0, 0.1);
  const Pose3d B = moved(A, {0.2, 0.0, 0.0}, -0.05);
  const Pose3d C = moved(A, {-0.1, 0.3, 0.1}, 0.12);
  const DepthImage d0 = kScene.renderDepth(*K, A, 5.0);
  const Pose3d A1 = lookingPose({1.0, -1.0, 1.4}, -1.0, 0.3);
  const DepthImage d1 = kScene.renderDepth(*K, A1, 5.0);

  Mapper fresh(config(ConsistencyMode::All));
  fresh.addFrame(0, 0.0, SensorFrame::depth(d0, K), C);
  fresh.addFrame(1, 0.1, SensorFrame::depth(d1, K), A1);

  SECTION("re-integrated after each correction") {
    Mapper mapper(config(ConsistencyMode::All));
    mapper.addFrame(0, 0.0, SensorFrame::depth(d0, K), A);
    mapper.addFrame(1, 0.1, SensorFrame::depth(d1, K), A1);
    mapper.updatePoses({{0, B}});
    mapper.reintegrateAll(Vec3d::Zero());
    mapper.updatePoses({{0, C}});
    mapper.reintegrateAll(Vec3d::Zero());
    CHECK(mapper.stats().reintegrated_frames == 2);
    CHECK(mapper.volume().exactlyEquals(fresh.volume()));
  }
  SECTION("both corrections arrive before the frame's turn") {
    Mapper mapper(config(ConsistencyMode::All));
    mapper.addFrame(0, 0.0, SensorFrame::depth(d0, K), A);
    mapper.addFrame(1, 0.1, SensorFrame::depth(d1, K), A1);
    mapper.updatePoses({{0, B}});
    mapper.updatePoses({{0, C}});
    CHECK(mapper.queuedFrames() == 1);
    mapper.reintegrateAll(Vec3d::Zero());
    CHECK(mapper.stats().reintegrated_frames == 1);
    CHECK(mapper.volume().exactlyEquals(fresh.volume()));
  }
}

TEST_CASE("pose changes below the gate are not re-integrated; none mode ignores corrections", "[mapper][gate]") {
  const auto K = smallCamera();
  const Pose3d A = lookingPose({0, 0, 1.2}, 0.0, 0.2);
  const DepthImage depth = kScene.renderDepth(*K, A, 5.0);
  Mapper all(config(ConsistencyMode::All));
  all.addFrame(0, 0.0, SensorFrame::depth(depth, K), A);
  CHECK(all.updatePoses({{0, moved(A, {0.005, 0, 0}, 0.0)}}) == 0);           // 5 mm < 1 cm
  CHECK(all.updatePoses({{0, moved(A, {0, 0, 0}, 0.3 * M_PI / 180)}}) == 0);  // 0.3 deg < 0.5 deg
  CHECK(all.updatePoses({{0, moved(A, {0.02, 0, 0}, 0.0)}}) == 1);
  CHECK(all.updatePoses({{42, A}}) == 0);  // an unknown frame is skipped

  Mapper none(config(ConsistencyMode::None));
  none.addFrame(0, 0.0, SensorFrame::depth(depth, K), A);
  CHECK(none.updatePoses({{0, moved(A, {0.5, 0, 0}, 0.2)}}) == 0);
  CHECK(none.queuedFrames() == 0);
  CHECK(none.keyframesKept() == 0);
}

TEST_CASE("each cycle keeps to its budget and takes the frames nearest the robot first", "[mapper][budget]") {
  const auto K = smallCamera();
  MapperConfig c = config(ConsistencyMode::All);
  c.reintegration.budget_frames = 2;
  c.reintegration.budget_ms = 1e6;
  c.set_cover.block_size_m = 1.0;
  Mapper mapper(c);
  std::map<FrameId, Pose3d> corrected;
  for (int i = 0; i < 6; ++i) {
    const Pose3d T = lookingPose({-3.0 + 1.2 * i, 0.0, 1.2}, 0.5 * i, 0.2);
    mapper.addFrame(i, 0.1 * i, SensorFrame::depth(kScene.renderDepth(*K, T, 5.0), K), T);
    corrected[i] = moved(T, {0.05, 0.05, 0}, 0.02);
  }
  REQUIRE(mapper.updatePoses(corrected) == 6);
  const Vec3d robot(3.0, 0.0, 1.2);  // nearest to frames 5 and 4
  const CycleReport first = mapper.reintegrate(robot);
  CHECK(first.frames == 2);
  CHECK(first.queued_left == 4);
  CHECK(mapper.keyframes().at(5).T_W_S_integrated.isApprox(corrected[5]));
  CHECK(mapper.keyframes().at(4).T_W_S_integrated.isApprox(corrected[4]));
  CHECK_FALSE(mapper.keyframes().at(0).T_W_S_integrated.isApprox(corrected[0]));
  CHECK(mapper.reintegrateAll(robot) == 4);
  CHECK(mapper.stats().reintegration_cycles == 3);
  CHECK(mapper.stats().reintegration_ms_max_cycle <= mapper.stats().reintegration_ms_total);
}

TEST_CASE("a solve dropping many frames de-integrates them in background cycles within the budget",
          "[mapper][budget][pruning]") {
  const auto K = smallCamera();
  MapperConfig c = config(ConsistencyMode::Keyframes);
  c.reintegration.budget_frames = 2;
  c.reintegration.budget_ms = 1e6;
  c.set_cover.solve_period_frames = 16;
  c.set_cover.solve_in_background = GENERATE(false, true);
  INFO("solve_in_background " << c.set_cover.solve_in_background);
  Mapper mapper(c);
  // Equal views: the first solve, at the 16th frame, keeps n_ob = 3 and drops 13. Its drops are
  // queued at once, or from the background when the next solve is due, at the 32nd frame.
  const int n = c.set_cover.solve_in_background ? 32 : 16;
  std::vector<DepthImage> depths;
  std::vector<Pose3d> poses;
  for (int i = 0; i < n; ++i) {
    poses.push_back(lookingPose({0.3, 0.1, 1.2}, 0.4, 0.2));
    depths.push_back(kScene.renderDepth(*K, poses.back(), 5.0));
    mapper.addFrame(i, 0.1 * i, SensorFrame::depth(depths.back(), K), poses.back());
    if (c.set_cover.solve_in_background && i == 30) CHECK(mapper.queuedFrames() == 0);  // not yet collected
  }
  REQUIRE(mapper.stats().pruning_solves == std::size_t(n / 16));
  const std::size_t dropped = mapper.queuedFrames();
  REQUIRE(dropped == std::size_t(16 - c.set_cover.n_ob));
  // The solve itself de-integrated nothing: every frame is still in the map.
  CHECK(mapper.volume().frameCount() == std::size_t(n));
  CHECK(mapper.stats().frames_dropped == 0);

  const std::size_t bound = (dropped + 1) / 2;  // budget_frames = 2 per cycle
  std::size_t cycles = 0;
  while (mapper.queuedFrames() > 0 && cycles <= bound) {
    const CycleReport r = mapper.reintegrate(poses.back().translation());
    CHECK(r.frames == 0);
    CHECK(r.frames_deintegrated >= 1);
    CHECK(r.frames_deintegrated <= 2);
    ++cycles;
  }
  CHECK(mapper.queuedFrames() == 0);
  CHECK(cycles == bound);
  CHECK(mapper.stats().frames_dropped == dropped);
  CHECK(mapper.stats().background_frames == dropped);

  // What is left equals integrating only the kept frames: the drops left the map exactly.
  const std::size_t kept = mapper.keyframesKept();
  CHECK(kept == std::size_t(n) - dropped);
  Mapper only_kept(config(ConsistencyMode::All));
  for (const auto& [id, kf] : mapper.keyframes()) only_kept.addFrame(id, kf.timestamp, SensorFrame::depth(depths[id], K), poses[id]);
  CHECK(mapper.volume().exactlyEquals(only_kept.volume()));
}

TEST_CASE("solves in the background give the map and keyframes of solves in the frame's cycle",
          "[mapper][pruning][determinism]") {
  const auto K = smallCamera();
  // A slow sweep with repeated views, so that each solve drops frames, and a correction of every
  // frame at frame 40 (while the solve of frame 32 is in flight in the background).
  const int n = 70;
  std::vector<Pose3d> odom, corrected;
  std::vector<DepthImage> depths;
  for (int i = 0; i < n; ++i) {
    odom.push_back(lookingPose({0.3 + 0.01 * (i % 35), 0.1, 1.2}, 0.4 + 0.01 * i, 0.2));
    corrected.push_back(moved(odom.back(), {0.03, -0.02, 0.0}, 0.02));
    depths.push_back(kScene.renderDepth(*K, odom.back(), 5.0));
  }
  const auto run = [&](bool background) {
    MapperConfig c = config(ConsistencyMode::Keyframes);
    c.set_cover.solve_period_frames = 8;
    c.set_cover.solve_in_background = background;
    c.reintegration.budget_frames = 2;
    c.reintegration.budget_ms = 1e6;
    auto mapper = std::make_unique<Mapper>(c);
    for (int i = 0; i < n; ++i) {
      mapper->addFrame(i, 0.1 * i, SensorFrame::depth(depths[std::size_t(i)], K), odom[std::size_t(i)]);
      if (i == 40) {
        std::map<FrameId, Pose3d> T;
        for (int j = 0; j <= i; ++j) T[FrameId(j)] = corrected[std::size_t(j)];
        mapper->updatePoses(T);
      }
      mapper->reintegrate(odom[std::size_t(i)].translation());
    }
    mapper->reintegrateAll(odom.back().translation());
    return mapper;
  };
  const auto in_cycle = run(false);
  const auto in_background = run(true);
  REQUIRE(in_cycle->stats().frames_dropped > 10);
  CHECK(in_background->stats().pruning_solves == in_cycle->stats().pruning_solves);
  CHECK(in_background->stats().frames_dropped > 10);
  // Either way the map is exactly its kept frames at the poses they were last given.
  for (const Mapper* mapper : {in_cycle.get(), in_background.get()}) {
    Mapper only_kept(config(ConsistencyMode::All));
    for (const auto& [id, kf] : mapper->keyframes()) {
      CHECK(kf.T_W_S_integrated.isApprox(id <= 40 ? corrected[id] : odom[id]));
      only_kept.addFrame(id, kf.timestamp, SensorFrame::depth(depths[id], K), kf.T_W_S_integrated);
    }
    CHECK(mapper->volume().exactlyEquals(only_kept.volume()));
  }

  // Without corrections the two keep the same frames and build the same map, bit for bit.
  corrected = odom;
  const auto plain_cycle = run(false);
  const auto plain_background = run(true);
  std::vector<FrameId> kept_cycle, kept_background;
  for (const auto& [id, kf] : plain_cycle->keyframes()) kept_cycle.push_back(id);
  for (const auto& [id, kf] : plain_background->keyframes()) kept_background.push_back(id);
  CHECK(kept_cycle == kept_background);
  CHECK(plain_cycle->volume().exactlyEquals(plain_background->volume()));
}

TEST_CASE("after a correction the pruner's cells of a re-integrated frame equal those of integrating it fresh",
          "[mapper][pruning][reintegration]") {
  const auto K = smallCamera();
  MapperConfig c = config(ConsistencyMode::Keyframes);
  c.set_cover.solve_period_frames = 1000;  // no solve before the end: the frame stays held
  Mapper mapper(c);
  const Pose3d A = lookingPose({0.5, 0.2, 1.2}, 0.3, 0.2);
  const Pose3d B = moved(A, {0.4, -0.3, 0.05}, 0.5);
  const DepthImage depth = kScene.renderDepth(*K, A, 5.0);
  mapper.addFrame(7, 0.0, SensorFrame::depth(depth, K), A);
  // The pruner's cells are those of the frame as the mapper stores it (depth quantized to
  // depth_unit_m), seen from where the map holds it.
  const DepthImage stored = EncodedFrame::fromDepth(depth, K, c.depth_unit_m).decodeDepth();
  const auto cellsAt = [&](const Pose3d& T) {
    return visibleCells(stored, *K, T, c.tsdf, c.integrator, c.set_cover.cell_size_vox);
  };
  REQUIRE(mapper.pruner() != nullptr);
  CHECK(mapper.pruner()->cellsOf(7) == cellsAt(A));

  REQUIRE(mapper.updatePoses({{7, B}}) == 1);
  mapper.reintegrateAll(B.translation());
  const CellSet fresh = cellsAt(B);
  CHECK_FALSE(fresh == cellsAt(A));
  CHECK(mapper.pruner()->cellsOf(7) == fresh);
  // The frame moved to the block of its new position.
  const auto block = mapper.pruner()->blockOf(B.translation());
  const auto in_block = mapper.pruner()->framesInBlock(block);
  CHECK(std::find(in_block.begin(), in_block.end(), FrameId(7)) != in_block.end());
}

TEST_CASE("the mapper reports the region it changed", "[mapper][dirty]") {
  const auto K = smallCamera();
  Mapper mapper(config(ConsistencyMode::All));
  CHECK(mapper.takeDirtyRegion().empty());
  const Pose3d A = lookingPose({0, 0, 1.2}, 0.0, 0.2);
  mapper.addFrame(0, 0.0, SensorFrame::depth(kScene.renderDepth(*K, A, 5.0), K), A);
  const openvdb::CoordBBox box = mapper.takeDirtyRegion();
  REQUIRE_FALSE(box.empty());
  CHECK(box.isInside(mapper.volume().activeBoundingBox()));
  CHECK(mapper.takeDirtyRegion().empty());
  mapper.updatePoses({{0, moved(A, {0.3, 0, 0}, 0)}});
  mapper.reintegrateAll(Vec3d::Zero());
  CHECK(mapper.takeDirtyRegion().isInside(mapper.volume().activeBoundingBox()));
}

TEST_CASE("submap mode moves rigid submaps by their anchors and fuses them", "[mapper][submap]") {
  const auto K = smallCamera();
  MapperConfig c = config(ConsistencyMode::Submap);
  c.submap_frames = 4;
  Mapper submap(c), none(config(ConsistencyMode::None));
  // The true path circles the room; odometry gains a constant offset from the 5th frame on.
  const auto truth = AnalyticScene::demoTrajectory(8);
  const Pose3d drift = moved(Pose3d::Identity(), {0.25, -0.15, 0.0}, 0.0);
  std::map<FrameId, Pose3d> corrections;
  for (int i = 0; i < 8; ++i) {
    const Pose3d odom = i < 4 ? truth[i] : drift * truth[i];
    const DepthImage depth = kScene.renderDepth(*K, truth[i], 5.0);
    submap.addFrame(i, 0.1 * i, SensorFrame::depth(depth, K), odom);
    none.addFrame(i, 0.1 * i, SensorFrame::depth(depth, K), odom);
    corrections[i] = truth[i];
  }
  CHECK(submap.stats().submaps == 2);
  CHECK(submap.updatePoses(corrections) == 1);  // only the second submap's anchor moved
  const double rmse_submap = meshRmse(extractMesh(submap.volume()), kScene);
  const double rmse_none = meshRmse(extractMesh(none.volume()), kScene);
  CHECK(rmse_submap < 0.5 * rmse_none);
  CHECK(rmse_submap < 0.5 * c.tsdf.voxel_size_m);
  CHECK_FALSE(submap.volume().hasExactState());
}

TEST_CASE("invalid mapper settings name the field", "[mapper][bad-input]") {
  MapperConfig c;
  c.reintegration.budget_ms = 0;
  CHECK_THROWS_WITH(Mapper(c), Catch::Contains("budget_ms"));
  c = MapperConfig{};
  c.submap_frames = 0;
  CHECK_THROWS_WITH(Mapper(c), Catch::Contains("submap_frames"));
  CHECK_THROWS_WITH(parseConsistencyMode("everything"), Catch::Contains("none, submap, all or keyframes"));
  Mapper m(config(ConsistencyMode::All));
  Pose3d bad = Pose3d::Identity();
  bad.translation().x() = std::nan("");
  CHECK_THROWS_WITH(m.updatePoses({{3, bad}}), Catch::Contains("frame 3"));
}
