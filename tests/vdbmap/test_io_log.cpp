// The log format: LogWriter -> openDataset round trip (depth and points, corrections, ground
// truth), and every bad-input case naming the file and line or frame.
#include "test_io_helpers.hpp"

#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/log_writer.hpp"
#include "vdbmap/io/png_io.hpp"

#include <Eigen/Geometry>

#include <cmath>

using namespace vdbmap;
using namespace vdbmap::io;
using vdbmap::test::readBytes;
using vdbmap::test::TempDir;
using vdbmap::test::writeText;

namespace {

constexpr double kPoseTolerance = 1e-7;  // 9 significant digits in frames.csv

SensorInfo smallDepthSensor() {
  SensorInfo s;
  s.kind = SensorKind::Depth;
  s.intrinsics = CameraIntrinsics{32, 24, 30.0, -31.0, 15.5, 11.5};
  s.depth_scale = 0.0005;
  s.min_range_m = 0.2;
  s.max_range_m = 6.0;
  return s;
}

Pose3d poseAt(int i) {
  return Pose3d(Eigen::Translation3d(0.1 * i, 0.02 * i * i, -0.3) * Eigen::AngleAxisd(0.05 * i, Eigen::Vector3d::UnitZ()));
}

DepthImage depthAt(int i) {
  DepthImage d(32, 24);
  for (int v = 0; v < 24; ++v)
    for (int u = 0; u < 32; ++u) d.at(u, v) = (u + v) % 7 == 0 ? 0.0f : 1.0f + 0.01f * float(u + 2 * v + i);
  return d;
}

// A 4-frame depth log with one correction and ground truth.
void writeSmallLog(const std::filesystem::path& folder) {
  LogWriter w(folder, smallDepthSensor());
  for (int i = 0; i < 4; ++i) {
    w.addDepthFrame(10.0 + 0.1 * i, depthAt(i), poseAt(i));
    w.addGroundTruth(10.0 + 0.1 * i, poseAt(i + 1));
  }
  w.addCorrection(10.3, {{10.0, poseAt(5)}, {10.2, poseAt(6)}});
  w.close();
}

}  // namespace

TEST_CASE("LogWriter then openDataset round trip (depth)", "[io][log]") {
  TempDir dir;
  writeSmallLog(dir / "log");
  CHECK(detectDatasetFormat(dir / "log") == DatasetFormat::Log);
  const auto src = openDataset(dir / "log");
  CHECK(src->format() == "log");
  REQUIRE(src->size() == 4);
  const SensorInfo& s = src->sensor();
  CHECK(s.kind == SensorKind::Depth);
  CHECK(s.intrinsics.width == 32);
  CHECK(s.intrinsics.fy == -31.0);
  CHECK(s.depth_scale == 0.0005);
  CHECK(s.min_range_m == 0.2);
  CHECK(s.max_range_m == 6.0);
  for (std::size_t i = 0; i < 4; ++i) {
    const Frame f = src->load(i);
    CHECK(f.data.isDepth());
    CHECK(f.timestamp_s == Approx(10.0 + 0.1 * double(i)).margin(1e-9));
    CHECK((f.T_W_S.matrix() - poseAt(int(i)).matrix()).cwiseAbs().maxCoeff() < kPoseTolerance);
    const DepthImage ref = depthAt(int(i));
    REQUIRE(f.data.depthImage().depth_m.size() == ref.depth_m.size());
    double max_err = 0;
    for (std::size_t k = 0; k < ref.depth_m.size(); ++k) max_err = std::max(max_err, std::abs(double(f.data.depthImage().depth_m[k] - ref.depth_m[k])));
    CHECK(max_err <= 0.5 * 0.0005 + 1e-6);
  }
  REQUIRE(src->corrections().size() == 1);
  const CorrectionEvent& ev = src->corrections()[0];
  CHECK(ev.event_frame == 3);
  CHECK(ev.event_timestamp_s == Approx(10.3));
  REQUIRE(ev.poses.size() == 2);
  CHECK(ev.poses[0].timestamp_s == src->record(0).timestamp_s);  // matched to the frames' stamps exactly
  CHECK(ev.poses[1].timestamp_s == src->record(2).timestamp_s);
  CHECK((ev.poses[1].T_W_S.matrix() - poseAt(6).matrix()).cwiseAbs().maxCoeff() < kPoseTolerance);
  REQUIRE(src->groundTruth().size() == 4);
  CHECK((src->groundTruth()[3].T_W_S.matrix() - poseAt(4).matrix()).cwiseAbs().maxCoeff() < kPoseTolerance);
  CHECK(src->findFrame(10.1).value() == 1);
  CHECK_FALSE(src->findFrame(10.15).has_value());
  // A path to frames.csv opens its folder.
  CHECK(openDataset(dir / "log" / "frames.csv")->size() == 4);
}

TEST_CASE("LogWriter then openDataset round trip (points)", "[io][log]") {
  TempDir dir;
  for (const char* ext : {".bin", ".ply", ".pcd"}) {
    INFO(ext);
    SensorInfo s;
    s.kind = SensorKind::Points;
    s.max_range_m = 30.0;
    LogWriterConfig opt;
    opt.points_extension = ext;
    opt.flush_every_frames = 1;
    const auto folder = dir / (std::string("pts") + ext);
    {
      LogWriter w(folder, s, opt);
      w.addPointsFrame(0.0, {Vec3f(1, 2, 3), Vec3f(4, 5, 6)}, poseAt(1));
      w.addPointsFrame(0.5, {Vec3f(-1, 0, 2)}, poseAt(2));
      // The destructor closes the log.
    }
    const auto src = openDataset(folder);
    CHECK(src->sensor().kind == SensorKind::Points);
    CHECK(src->sensor().max_range_m == 30.0);
    REQUIRE(src->size() == 2);
    const Frame f = src->load(0);
    CHECK_FALSE(f.data.isDepth());
    CHECK(f.data.points_S() == PointCloud{Vec3f(1, 2, 3), Vec3f(4, 5, 6)});
    CHECK(src->load(1).data.points_S().size() == 1);
  }
}

TEST_CASE("LogWriter refuses misuse", "[io][log][bad-input]") {
  TempDir dir;
  LogWriter w(dir / "log", smallDepthSensor());
  w.addDepthFrame(1.0, depthAt(0), poseAt(0));
  CHECK_THROWS_AS(w.addDepthFrame(1.0, depthAt(1), poseAt(1)), std::invalid_argument);       // same time
  CHECK_THROWS_AS(w.addDepthFrame(0.5, depthAt(1), poseAt(1)), std::invalid_argument);       // earlier
  CHECK_THROWS_AS(w.addDepthFrame(2.0, DepthImage(10, 10), poseAt(1)), std::invalid_argument);  // wrong size
  Pose3d bad = poseAt(1);
  bad.linear() *= 1.1;
  CHECK_THROWS_AS(w.addDepthFrame(2.0, depthAt(1), bad), std::invalid_argument);
  CHECK_THROWS_AS(w.addPointsFrame(2.0, {}, poseAt(1)), std::invalid_argument);  // depth sensor
  CHECK_THROWS_AS(w.addCorrection(7.0, {{1.0, poseAt(2)}}), std::invalid_argument);  // unknown event frame
  CHECK_THROWS_AS(w.addCorrection(1.0, {{3.0, poseAt(2)}}), std::invalid_argument);  // unknown pose frame
  w.close();
  CHECK_THROWS_AS(w.addDepthFrame(5.0, depthAt(1), poseAt(1)), std::logic_error);
  // A second writer on the same folder refuses to overwrite the log.
  CHECK_THROWS_AS(LogWriter(dir / "log", smallDepthSensor()), std::runtime_error);
}

TEST_CASE("LogWriter overwriting a log drops the old log's corrections and ground truth", "[io][log]") {
  TempDir dir;
  {
    LogWriter w(dir / "log", smallDepthSensor());
    w.addDepthFrame(1.0, depthAt(0), poseAt(0));
    w.addDepthFrame(2.0, depthAt(1), poseAt(1));
    w.addCorrection(2.0, {{1.0, poseAt(2)}});
    w.addGroundTruth(1.0, poseAt(0));
    w.close();
  }
  REQUIRE(openDataset(dir / "log")->corrections().size() == 1);
  LogWriterConfig options;
  options.overwrite = true;
  {
    LogWriter w(dir / "log", smallDepthSensor(), options);
    w.addDepthFrame(1.0, depthAt(0), poseAt(0));
    w.addDepthFrame(2.0, depthAt(1), poseAt(1));
    w.close();
  }
  const auto log = openDataset(dir / "log");
  CHECK(log->size() == 2);
  CHECK(log->corrections().empty());  // a stale correction would move the new frames
  CHECK(log->groundTruth().empty());
}

TEST_CASE("openDataset rejects bad logs naming the file and line", "[io][log][bad-input]") {
  TempDir dir;
  const auto log = dir / "log";
  writeSmallLog(log);
  const std::string csv = readBytes(log / "frames.csv");
  const std::string header = "timestamp,file,tx,ty,tz,qx,qy,qz,qw\n";

  SECTION("missing folder") {
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(dir / "nothing"), "nothing", "no such folder");
  }
  SECTION("folder of something else") {
    std::filesystem::create_directories(dir / "empty");
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(dir / "empty"), "empty", "not a recognised");
  }
  SECTION("missing sensor.json when forced to read a log") {
    std::filesystem::remove(log / "sensor.json");
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(log, DatasetFormat::Log), "sensor.json", "no such file");
  }
  SECTION("sensor.json without a key") {
    writeText(log / "sensor.json", R"({"kind": "depth", "width": 32, "height": 24, "fx": 30, "fy": 30, "cx": 15})");
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(log), "sensor.json", "\"cy\"");
  }
  SECTION("sensor.json that is not JSON") {
    writeText(log / "sensor.json", "{kind: depth");
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(log), "sensor.json", "invalid JSON");
  }
  SECTION("frames.csv with a wrong header") {
    writeText(log / "frames.csv", "time,file\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(log), "frames.csv:1:", "header");
  }
  SECTION("timestamps out of order") {
    writeText(log / "frames.csv", header + "1.0,depth/000000.png,0,0,0,0,0,0,1\n2.0,depth/000001.png,0,0,0,0,0,0,1\n"
                                           "1.5,depth/000002.png,0,0,0,0,0,0,1\n");
    std::filesystem::remove_all(log / "corrections");
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(log), "frames.csv:4:", "time order");
  }
  SECTION("a line with too few fields") {
    writeText(log / "frames.csv", header + "1.0,depth/000000.png,0,0,0\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(log), "frames.csv:2:", "9 comma-separated");
  }
  SECTION("a line with an extra field, as formats.md says") {
    writeText(log / "frames.csv", header + "1.0,depth/000000.png,0,0,0,0,0,0,1,7\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(log), "frames.csv:2:", "9 comma-separated", "found 10");
  }
  SECTION("a header with an extra column") {
    writeText(log / "frames.csv", "timestamp,file,tx,ty,tz,qx,qy,qz,qw,confidence\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(log), "frames.csv:1:", "header");
  }
  SECTION("DBL_MAX as depth_scale or max_range_m: refused in a short message naming the key") {
    for (const char* key : {"depth_scale", "max_range_m"}) {
      std::string json = R"({"kind": "depth", "width": 64, "height": 48, "fx": 50.0, "fy": 50.0, "cx": 31.5,
                             "cy": 23.5, "depth_scale": 0.001, "max_range_m": 5.0})";
      const std::string from = std::string("\"") + key + "\": " + (std::string(key) == "depth_scale" ? "0.001" : "5.0");
      json.replace(json.find(from), from.size(), std::string("\"") + key + "\": 1.7976931348623157e308");
      writeText(log / "sensor.json", json);
      try {
        openDataset(log);
        FAIL("accepted " << key << " = DBL_MAX");
      } catch (const std::exception& e) {
        const std::string msg = e.what();
        CHECK_THAT(msg, Catch::Contains(key) && Catch::Contains("1.79769e+308"));
        CHECK(msg.size() < 200);
      }
    }
  }
  SECTION("a negative fx, which formats.md does not allow") {
    writeText(log / "sensor.json", R"({"kind": "depth", "width": 64, "height": 48, "fx": -50.0, "fy": 50.0,
                                     "cx": 31.5, "cy": 23.5, "depth_scale": 0.001})");
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(log), "sensor.json", "fx");
  }
  SECTION("a pose with NaN fails only that frame") {
    writeText(log / "frames.csv", header + "10.0,depth/000000.png,0,0,0,0,0,0,1\n10.1,depth/000001.png,0,nan,0,0,0,0,1\n"
                                           "10.2,depth/000002.png,0,0,0,0,0,0,1\n10.3,depth/000003.png,0,0,0,0,0,0,1\n");
    const auto src = openDataset(log);
    REQUIRE(src->size() == 4);
    CHECK_NOTHROW(src->load(0));
    CHECK_THROWS_AS(src->load(1), BadFrameError);
    VDBMAP_REQUIRE_THROWS_MENTIONING(src->load(1), "frame 1", "frames.csv:3", "non-finite");
    CHECK_NOTHROW(src->load(2));
    try {
      src->load(1);
    } catch (const BadFrameError& e) {
      CHECK(e.frameIndex() == 1);
    }
  }
  SECTION("a non-orthonormal rotation (quaternion far from unit length) fails only that frame") {
    writeText(log / "frames.csv", header + "10.0,depth/000000.png,0,0,0,0,0,0,1\n10.1,depth/000001.png,0,0,0,0.5,0.5,0.5,0.1\n"
                                           "10.2,depth/000002.png,0,0,0,0,0,0,1\n10.3,depth/000003.png,0,0,0,0,0,0,1\n");
    const auto src = openDataset(log);
    VDBMAP_REQUIRE_THROWS_MENTIONING(src->load(1), "frame 1", "frames.csv:3", "quaternion norm");
  }
  SECTION("a missing frame file") {
    std::filesystem::remove(log / "depth" / "000002.png");
    const auto src = openDataset(log);
    CHECK_NOTHROW(src->load(1));
    CHECK_THROWS_AS(src->load(2), BadFrameError);
    VDBMAP_REQUIRE_THROWS_MENTIONING(src->load(2), "frame 2", "frames.csv:4", "000002.png", "no such file");
  }
  SECTION("a corrupt frame PNG") {
    const std::string png = readBytes(log / "depth" / "000001.png");
    writeText(log / "depth" / "000001.png", png.substr(0, png.size() / 2));
    const auto src = openDataset(log);
    CHECK_THROWS_AS(src->load(1), BadFrameError);
    VDBMAP_REQUIRE_THROWS_MENTIONING(src->load(1), "frame 1", "000001.png", "truncated");
  }
  SECTION("a depth image of the wrong size") {
    writeDepthPng(log / "depth" / "000003.png", DepthImage(16, 12, 1.0f), 0.0005);
    const auto src = openDataset(log);
    CHECK_THROWS_AS(src->load(3), BadFrameError);
    VDBMAP_REQUIRE_THROWS_MENTIONING(src->load(3), "frame 3", "000003.png", "16x12", "32x24");
  }
  SECTION("a correction whose event names no frame") {
    writeText(log / "corrections" / "11.000000.txt", "10.0 0 0 0 0 0 0 1\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(log), "11.000000.txt", "names no frame");
  }
  SECTION("a correction pose after its event, where the odometry is not known yet") {
    writeText(log / "corrections" / "10.100000.txt", "# optimised\n10.05 0 0 0 0 0 0 1\n10.15 0 0 0 0 0 0 1\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(log), "10.100000.txt:3:", "outside the frames up to the event");
  }
  SECTION("a correction pose before the first frame") {
    writeText(log / "corrections" / "10.100000.txt", "9.5 0 0 0 0 0 0 1\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(log), "10.100000.txt:1:", "outside the frames up to the event");
  }
  SECTION("a correction file with a bad name") {
    writeText(log / "corrections" / "loop.txt", "10.0 0 0 0 0 0 0 1\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(log), "loop.txt", "<event_timestamp>.txt");
  }
  SECTION("absolute frame paths are accepted") {
    writeText(log / "frames.csv", header + "10.0," + (log / "depth" / "000000.png").string() + ",0,0,0,0,0,0,1\n");
    std::filesystem::remove_all(log / "corrections");
    CHECK(openDataset(log)->load(0).data.depthImage().width == 32);
  }
  CHECK(csv.rfind(header, 0) == 0);
}
