// ROS1 bags written by ROS's own python3-rosbag (tests/io/make_test_bag.py) read as frame sources:
// the topic listing; a bag with a keyframe Path gives the same map as the equivalent folder log;
// poses published at other stamps are interpolated at the depth stamps and moved by the
// extrinsic; bad bags (truncated, unknown encoding, missing topic, no CameraInfo, stamps out of
// order, distortion) are refused by name. Skipped (77) without bag support or python3-rosbag.
#include "common/drifting_circle.hpp"
#include "common/fresh_dir.hpp"
#include "common/shared_data.hpp"

#include "vdbmap/file_error.hpp"
#include "vdbmap/io/log_replay.hpp"
#include "vdbmap/io/log_writer.hpp"
#include "vdbmap/io/ros_bag.hpp"
#include "vdbmap/mapper.hpp"
#include "vdbmap/testing/analytic_scene.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>

#include <sys/wait.h>

using namespace vdbmap;
namespace fs = std::filesystem;

namespace {

/// A log of 6 analytic frames with drifting odometry and a correction of every frame at the last.
fs::path writeLog(const fs::path& dir) {
  io::SensorInfo sensor;
  sensor.intrinsics = CameraIntrinsics{160, 120, 96.8, 96.8, 79.5, 59.5};
  const testing::AnalyticScene scene = testing::AnalyticScene::demoRoom();
  io::LogWriter log(dir / "log", sensor);
  std::vector<io::StampedPose> corrected;
  for (int i = 0; i < 6; ++i) {
    log.addDepthFrame(0.1 * (i + 1), scene.renderDepth(sensor.intrinsics, test::circlePose(i), 5.0), test::circleOdometry(i));
    corrected.push_back({0.1 * (i + 1), test::circlePose(i)});
  }
  log.addCorrection(0.6, corrected);
  return dir / "log";
}

/// Runs make_test_bag.py; skips the test case (77) when rosbag's Python library is missing.
void makeBag(const fs::path& log, const fs::path& bag, const std::string& options = "") {
  if (!io::rosBagSupport()) {
    std::printf("skipped: this build reads no ROS bags\n");
    std::exit(test::kSkipReturnCode);
  }
  const std::string cmd = "/usr/bin/python3 " + std::string(VDBMAP_SOURCE_DIR) + "/tests/io/make_test_bag.py " +
                          log.string() + " " + bag.string() + " " + options + " > " + bag.string() + ".log 2>&1";
  const int status = std::system(cmd.c_str());
  if (WIFEXITED(status) && WEXITSTATUS(status) == test::kSkipReturnCode) {
    std::printf("skipped: python3-rosbag is not installed\n");
    std::exit(test::kSkipReturnCode);
  }
  REQUIRE(status == 0);
}

}  // namespace

TEST_CASE("a bag's topics, types, counts and span are listed", "[io][rosbag]") {
  const fs::path dir = test::freshDir("vdbmap_bag_info");
  makeBag(writeLog(dir), dir / "run.bag");
  const io::RosBagInfo info = io::inspectRosBag(dir / "run.bag");
  REQUIRE(info.topics.size() == 4);
  std::map<std::string, std::pair<std::string, std::size_t>> by;
  for (const io::RosBagTopic& t : info.topics) by[t.name] = {t.type, t.messages};
  CHECK(by.at("/camera/depth/image_rect_raw") == std::make_pair(std::string("sensor_msgs/Image"), std::size_t(6)));
  CHECK(by.at("/camera/depth/camera_info").first == "sensor_msgs/CameraInfo");
  CHECK(by.at("/odometry") == std::make_pair(std::string("nav_msgs/Odometry"), std::size_t(6)));
  CHECK(by.at("/loop_fusion/pose_graph_path") == std::make_pair(std::string("nav_msgs/Path"), std::size_t(1)));
  CHECK(info.messages == 14);
  CHECK(info.start_s == Approx(0.1));
  CHECK(info.end_s == Approx(0.6));
}

TEST_CASE("a bag with a keyframe Path gives the same map as the equivalent folder log", "[io][rosbag]") {
  const fs::path dir = test::freshDir("vdbmap_bag_equal");
  const fs::path log = writeLog(dir);
  for (const char* encoding : {"16UC1", "32FC1"}) {
    INFO(encoding);
    makeBag(log, dir / "run.bag", std::string("--encoding ") + encoding + " --every 2");
    const auto bag = io::openRosBag(dir / "run.bag");
    const auto folder = io::openDataset(log);
    REQUIRE(bag->size() == folder->size());
    REQUIRE(bag->corrections().size() == 1);
    CHECK(bag->corrections()[0].poses.size() == 3);  // every other frame's corrected pose
    CHECK(bag->corrections()[0].event_frame == 5);
    MapperConfig mc;
    mc.mode = ConsistencyMode::All;
    mc.tsdf.voxel_size_m = 0.1;
    Mapper from_bag(mc), from_folder(mc);
    replayLog(*bag, from_bag, ReplayConfig{});
    // The folder log with the same subset of corrected poses.
    io::SensorInfo sensor = folder->sensor();
    {
      io::LogWriter thin(dir / (std::string("thin_") + encoding), sensor);
      for (std::size_t i = 0; i < folder->size(); ++i) {
        const io::Frame f = folder->load(i);
        thin.addDepthFrame(f.timestamp_s, f.data.depthImage(), f.T_W_S);
      }
      std::vector<io::StampedPose> every_other;
      for (std::size_t k = 0; k < folder->corrections()[0].poses.size(); k += 2) every_other.push_back(folder->corrections()[0].poses[k]);
      thin.addCorrection(folder->corrections()[0].event_timestamp_s, every_other);
    }
    replayLog(*io::openDataset(dir / (std::string("thin_") + encoding)), from_folder, ReplayConfig{});
    if (std::string(encoding) == "16UC1") {
      CHECK(from_bag.volume().exactlyEquals(from_folder.volume()));
    } else {  // metres in float32 from the same millimetres: the same points within float rounding
      CHECK(from_bag.volume().frameCount() == from_folder.volume().frameCount());
    }
  }
}

TEST_CASE("poses at other stamps are interpolated at the depth stamps and moved by the extrinsic", "[io][rosbag]") {
  const fs::path dir = test::freshDir("vdbmap_bag_interp");
  const fs::path log = writeLog(dir);
  // The body: 0.5 m/s along x turning at 0.2 rad/s, published every 30 ms from t = 0.15 s.
  makeBag(log, dir / "run.bag", "--analytic-odometry --odometry-start 0.15 --pose-type transform");
  io::RosBagConfig options;
  options.T_B_S = poseFromTranslationQuaternion(Vec3d(0.1, 0.0, -0.05), 0.0, 0.0, std::sin(0.1), std::cos(0.1));
  const auto bag = io::openRosBag(dir / "run.bag", options);
  REQUIRE(bag->size() == 5);  // the image at 0.1 s precedes the pose stream: skipped
  CHECK(bag->description().find("1 images outside the pose stream skipped") != std::string::npos);
  for (std::size_t i = 0; i < bag->size(); ++i) {
    const double t = bag->record(i).timestamp_s;
    Pose3d body = Pose3d::Identity();
    body.linear() = Eigen::AngleAxisd(0.2 * t, Vec3d::UnitZ()).toRotationMatrix();
    body.translation() = Vec3d(0.5 * t, 0.0, 1.0);
    const Pose3d expected = body * options.T_B_S;
    CHECK((bag->record(i).T_W_S.matrix() - expected.matrix()).cwiseAbs().maxCoeff() < 1e-6);
  }
}

TEST_CASE("bad bags are refused naming the file, the topic and the stamp", "[io][rosbag][hostile]") {
  const fs::path dir = test::freshDir("vdbmap_bag_bad");
  const fs::path log = writeLog(dir);
  makeBag(log, dir / "good.bag");
  fs::copy_file(dir / "good.bag", dir / "cut.bag");
  fs::resize_file(dir / "cut.bag", fs::file_size(dir / "good.bag") / 2);
  CHECK_THROWS_AS(io::openRosBag(dir / "cut.bag"), FileError);
  CHECK_THROWS_WITH(io::openRosBag(dir / "cut.bag"), Catch::Contains("cut.bag"));

  io::RosBagConfig missing;
  missing.depth_topic = "/nope";
  CHECK_THROWS_WITH(io::openRosBag(dir / "good.bag", missing),
                    Catch::Contains("no topic /nope") && Catch::Contains("/camera/depth/image_rect_raw"));

  makeBag(log, dir / "rgb.bag", "--encoding rgb8");
  CHECK_THROWS_WITH(io::openRosBag(dir / "rgb.bag"), Catch::Contains("/camera/depth/image_rect_raw at 0.100000") &&
                                                         Catch::Contains("encoding 'rgb8'"));
  makeBag(log, dir / "noinfo.bag", "--no-camera-info");
  CHECK_THROWS_WITH(io::openRosBag(dir / "noinfo.bag"), Catch::Contains("no sensor_msgs/CameraInfo topic"));
  makeBag(log, dir / "swapped.bag", "--swap-stamps");
  CHECK_THROWS_WITH(io::openRosBag(dir / "swapped.bag"), Catch::Contains("is not after the previous"));
  makeBag(log, dir / "distorted.bag", "--distorted");
  CHECK_THROWS_WITH(io::openRosBag(dir / "distorted.bag"), Catch::Contains("distortion model 'plumb_bob'"));
  CHECK_THROWS_WITH(io::openRosBag(dir / "missing.bag"), Catch::Contains("no such bag file"));
}
