// Poses between stamps, and corrections of a subset of stamps applied to every frame: analytic
// cases, and a replayed log whose correction lists every other frame against integrating from
// scratch at the interpolated poses (bit for bit).
#include "vdbmap/io/log_replay.hpp"
#include "vdbmap/io/log_writer.hpp"
#include "vdbmap/io/pose_interpolation.hpp"
#include "vdbmap/mapper.hpp"
#include "vdbmap/testing/analytic_scene.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

using namespace vdbmap;
using io::StampedPose;

namespace {

Pose3d pose(double x, double y, double z, double yaw) {
  Pose3d T = Pose3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Vec3d::UnitZ()).toRotationMatrix();
  T.translation() = Vec3d(x, y, z);
  return T;
}

double yawOf(const Pose3d& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }

/// Largest difference of two poses' matrices.
double gap(const Pose3d& a, const Pose3d& b) { return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff(); }

constexpr double kTol = 1e-12;

}  // namespace

TEST_CASE("interpolatePose is linear in translation and slerps rotation", "[io][interpolation]") {
  const Pose3d a = pose(0, 0, 1, 0.2), b = pose(2, -4, 3, 1.0);
  const Pose3d m = io::interpolatePose(a, b, 0.25);
  CHECK((m.translation() - Vec3d(0.5, -1.0, 1.5)).norm() < kTol);
  CHECK(yawOf(m) == Approx(0.4).margin(kTol));
  CHECK(gap(io::interpolatePose(a, b, 0.0), a) < kTol);
  CHECK(gap(io::interpolatePose(a, b, 1.0), b) < kTol);
}

TEST_CASE("poseAt is exact at stamps, interpolated between, empty outside", "[io][interpolation]") {
  const std::vector<StampedPose> track{{1.0, pose(0, 0, 0, 0)}, {2.0, pose(1, 0, 0, 0.5)}, {4.0, pose(1, 2, 0, 0.5)}};
  CHECK(io::poseAt(track, 2.0)->matrix() == track[1].T_W_S.matrix());
  CHECK((io::poseAt(track, 3.0)->translation() - Vec3d(1, 1, 0)).norm() < kTol);
  CHECK(yawOf(*io::poseAt(track, 1.5)) == Approx(0.25).margin(kTol));
  CHECK_FALSE(io::poseAt(track, 0.999).has_value());
  CHECK_FALSE(io::poseAt(track, 4.001).has_value());
  CHECK_FALSE(io::poseAt({}, 1.0).has_value());
}

TEST_CASE("a correction of some stamps moves every frame: exact at them, interpolated between, held outside",
          "[io][interpolation]") {
  // Odometry along x; the correction at t = 1 is a shift of +0.1 m in y, at t = 3 a yaw of 0.2 rad
  // about the origin plus the shift.
  std::vector<StampedPose> frames;
  for (int i = 0; i <= 8; ++i) frames.push_back({0.5 * i, pose(0.5 * i, 0, 1, 0)});
  const Pose3d C1 = pose(0, 0.1, 0, 0), C3 = pose(0, 0.1, 0, 0.2);
  const std::vector<StampedPose> corrected{{1.0, C1 * frames[2].T_W_S}, {3.0, C3 * frames[6].T_W_S}};
  const std::vector<Pose3d> out = io::applyCorrection(frames, corrected);
  REQUIRE(out.size() == frames.size());
  CHECK(out[2].matrix() == corrected[0].T_W_S.matrix());  // exactly the listed pose
  CHECK(out[6].matrix() == corrected[1].T_W_S.matrix());
  CHECK(gap(out[0], C1 * frames[0].T_W_S) < kTol);        // before the first: held
  CHECK(gap(out[8], C3 * frames[8].T_W_S) < kTol);        // after the last: held
  CHECK(gap(out[4], io::interpolatePose(C1, C3, 0.5) * frames[4].T_W_S) < kTol);  // half way
  CHECK(yawOf(out[4]) == Approx(0.1).margin(kTol));
  // A constant correction, known at one stamp between frames, moves every frame by itself.
  const Pose3d C = pose(0.3, -0.2, 0.05, -0.1);
  const std::vector<Pose3d> one = io::applyCorrection(frames, {{1.25, C * *io::poseAt(frames, 1.25)}});
  for (std::size_t i = 0; i < frames.size(); ++i) CHECK(gap(one[i], C * frames[i].T_W_S) < 1e-9);
  CHECK_THROWS_WITH(io::applyCorrection(frames, {{5.0, C}}), Catch::Contains("outside the frames' span"));
  CHECK_THROWS_AS(io::applyCorrection(frames, {}), std::invalid_argument);
}

TEST_CASE("a replayed log whose correction lists every other frame equals integrating at the interpolated poses",
          "[io][interpolation][replay]") {
  const testing::AnalyticScene scene = testing::AnalyticScene::demoRoom();
  io::SensorInfo sensor;
  sensor.intrinsics = CameraIntrinsics{160, 120, 96.8, 96.8, 79.5, 59.5};
  sensor.depth_scale = 0.001;
  sensor.max_range_m = 5.0;
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "vdbmap_subset_correction";
  std::filesystem::remove_all(dir);
  // Odometry drifting in yaw (0.02 rad per frame) and y; the truth is the camera circling the room.
  std::vector<StampedPose> odometry, truth;
  {
    io::LogWriter log(dir, sensor);
    for (int i = 0; i < 8; ++i) {
      const double t = 0.1 * i;
      const Pose3d T_true = lookingPose({0.4 * std::cos(0.5 * i), 0.4 * std::sin(0.5 * i), 1.2}, 0.5 * i, 0.15);
      const Pose3d drift = pose(0.0, 0.02 * i, 0.0, 0.02 * i);
      truth.push_back({t, T_true});
      odometry.push_back({t, drift * T_true});
      log.addDepthFrame(t, scene.renderDepth(sensor.intrinsics, T_true, 5.0), odometry.back().T_W_S);
    }
    std::vector<StampedPose> keyframes;  // every other frame's true pose, as a keyframe back end gives
    for (int i = 0; i < 8; i += 2) keyframes.push_back(truth[std::size_t(i)]);
    log.addCorrection(0.7, keyframes);
  }
  const std::unique_ptr<io::FrameSource> source = io::openDataset(dir);
  REQUIRE(source->corrections().size() == 1);
  CHECK(source->corrections()[0].poses.size() == 4);

  MapperConfig mc;
  mc.mode = ConsistencyMode::All;
  mc.tsdf.voxel_size_m = 0.1;
  mc.integrator.max_range_m = 5.0;
  Mapper replayed(mc);
  const ReplayResult r = replayLog(*source, replayed, ReplayConfig{});
  CHECK(r.correction_events == 1);
  // Loading each frame before its cycle instead of during the one before changes only the timing.
  ReplayConfig serial;
  serial.load_ahead = false;
  Mapper replayed_serially(mc);
  const ReplayResult s = replayLog(*source, replayed_serially, serial);
  CHECK(s.correction_events == 1);
  CHECK(s.frames_integrated == r.frames_integrated);
  CHECK(replayed_serially.volume().exactlyEquals(replayed.volume()));

  // The oracle: every frame integrated once, from scratch, at its interpolated corrected pose.
  std::vector<StampedPose> listed_odometry;
  for (std::size_t i = 0; i < source->size(); ++i) listed_odometry.push_back({source->record(i).timestamp_s, source->record(i).T_W_S});
  const std::vector<Pose3d> corrected = io::applyCorrection(listed_odometry, source->corrections()[0].poses);
  mc.mode = ConsistencyMode::None;
  Mapper scratch(mc);
  for (std::size_t i = 0; i < source->size(); ++i) {
    const io::Frame f = source->load(i);
    scratch.addFrame(i, f.timestamp_s, f.data, corrected[i]);
  }
  CHECK(replayed.volume().exactlyEquals(scratch.volume()));
  // The frames between keyframes moved too (not only the listed ones), toward the truth.
  CHECK((corrected[3].translation() - truth[3].T_W_S.translation()).norm() <
        (odometry[3].T_W_S.translation() - truth[3].T_W_S.translation()).norm());
  // After the last keyframe the correction is held (poses in the log carry 9 significant digits).
  CHECK((corrected[7].translation() - (truth[6].T_W_S * odometry[6].T_W_S.inverse() * odometry[7].T_W_S).translation())
            .norm() < 1e-6);
  std::filesystem::remove_all(dir);
}
