// `vdbmap integrate` in a re-integrating mode saves MAP.keyframes, and `vdbmap reintegrate`
// corrects the saved map with a trajectory of any subset of stamps: equal, bit for bit, to
// integrating the frames from scratch at the interpolated corrected poses; --extrinsic turns body
// poses into camera poses; bad inputs are named.
#include "common/drifting_circle.hpp"
#include "tools/cli_test_util.hpp"

#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/log_writer.hpp"
#include "vdbmap/io/pose_interpolation.hpp"
#include "vdbmap/mapper.hpp"
#include "vdbmap/testing/analytic_scene.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

namespace fs = std::filesystem;
using namespace vdbmap;

namespace {
int run(const std::string& args, const fs::path& out_file) { return test::runCli(args, out_file); }
using test::slurp;

}  // namespace

TEST_CASE("vdbmap reintegrate corrects a saved map exactly as integrating at the corrected poses", "[cli][reintegrate]") {
  const fs::path dir = test::freshDir("vdbmap_cli_reintegrate");
  const fs::path out = dir / "out.txt";
  const testing::AnalyticScene scene = testing::AnalyticScene::demoRoom();
  io::SensorInfo sensor;
  sensor.intrinsics = CameraIntrinsics{160, 120, 96.8, 96.8, 79.5, 59.5};
  sensor.max_range_m = 5.0;
  {
    io::LogWriter log(dir / "log", sensor);
    for (int i = 0; i < 8; ++i) log.addDepthFrame(0.1 * i, scene.renderDepth(sensor.intrinsics, test::circlePose(i), 5.0), test::circleOdometry(i));
  }
  std::vector<io::StampedPose> keyposes;  // the true pose of every other frame, as a keyframe back end gives
  for (int i = 0; i < 8; i += 2) keyposes.push_back({0.1 * i, test::circlePose(i)});
  io::writeTumTrajectory(dir / "corrected.txt", keyposes);

  REQUIRE(run("integrate " + (dir / "log").string() + " --mode all --voxel-size 0.1 -o " + (dir / "map.vdb").string(), out) == 0);
  CHECK(fs::exists(dir / "map.keyframes"));
  REQUIRE(run("reintegrate " + (dir / "map.vdb").string() + " --trajectory " + (dir / "corrected.txt").string() +
                  " -o " + (dir / "fixed.vdb").string(),
              out) == 0);
  INFO(slurp(out));
  CHECK(slurp(out).find("re-integrated") != std::string::npos);

  // The oracle: every frame of the log integrated once at its interpolated corrected pose.
  const auto source = io::openDataset(dir / "log");
  std::vector<io::StampedPose> odom;
  for (std::size_t i = 0; i < source->size(); ++i) odom.push_back({source->record(i).timestamp_s, source->record(i).T_W_S});
  const std::vector<Pose3d> corrected = io::applyCorrection(odom, io::readTumTrajectory(dir / "corrected.txt"));
  MapperConfig mc;
  mc.mode = ConsistencyMode::None;
  mc.tsdf.voxel_size_m = 0.1;
  mc.integrator.min_range_m = sensor.min_range_m;
  mc.integrator.max_range_m = sensor.max_range_m;
  Mapper scratch(mc);
  for (std::size_t i = 0; i < source->size(); ++i) scratch.addFrame(i, odom[i].timestamp_s, source->load(i).data, corrected[i]);
  CHECK(TsdfVolume::load(dir / "fixed.vdb").exactlyEquals(scratch.volume()));
  CHECK_FALSE(TsdfVolume::load(dir / "map.vdb").exactlyEquals(scratch.volume()));  // the correction did something

  // Body poses with a body->camera extrinsic give the same camera poses.
  const Pose3d T_B_S = poseFromTranslationQuaternion(Vec3d(0.1, 0.0, -0.05), 0.0, 0.0, std::sin(0.1), std::cos(0.1));
  std::vector<io::StampedPose> body = keyposes;
  for (io::StampedPose& p : body) p.T_W_S = p.T_W_S * T_B_S.inverse();
  io::writeTumTrajectory(dir / "body.txt", body);
  REQUIRE(run("reintegrate " + (dir / "map.vdb").string() + " --trajectory " + (dir / "body.txt").string() +
                  " --extrinsic 0.1,0,-0.05,0,0,0.0998334166,0.9950041653 -o " + (dir / "fixed_body.vdb").string(),
              out) == 0);
  const KeyframeStore a = KeyframeStore::load(dir / "fixed.keyframes"), b = KeyframeStore::load(dir / "fixed_body.keyframes");
  for (const auto& [id, kf] : a)
    CHECK((kf.T_W_S_integrated.matrix() - b.at(id).T_W_S_integrated.matrix()).cwiseAbs().maxCoeff() < 1e-6);

  // Named failures, nothing written.
  io::writeTumTrajectory(dir / "later.txt", {{50.0, test::circlePose(0)}});
  CHECK(run("reintegrate " + (dir / "map.vdb").string() + " --trajectory " + (dir / "later.txt").string() + " -o " +
                (dir / "x.vdb").string(),
            out) != 0);
  CHECK(slurp(out).find("no pose within the keyframes' time span") != std::string::npos);
  CHECK(run("reintegrate " + (dir / "map.vdb").string() + " --trajectory " + (dir / "corrected.txt").string() + " -o " +
                (dir / "fixed.vdb").string(),
            out) != 0);
  CHECK(slurp(out).find("--overwrite") != std::string::npos);
  REQUIRE(run("integrate " + (dir / "log").string() + " --mode none --voxel-size 0.1 -o " + (dir / "plain.vdb").string(), out) == 0);
  CHECK_FALSE(fs::exists(dir / "plain.keyframes"));
  CHECK(run("reintegrate " + (dir / "plain.vdb").string() + " --trajectory " + (dir / "corrected.txt").string() + " -o " +
                (dir / "x.vdb").string(),
            out) != 0);
  CHECK(slurp(out).find("no keyframe store") != std::string::npos);
  CHECK_FALSE(fs::exists(dir / "x.vdb"));
}
