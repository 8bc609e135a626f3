// The file layer's error type: every reader and writer reports a missing, unreadable or malformed
// file as vdbmap::FileError (what the Python bindings turn into OSError), with the file named, while
// bad parameters stay std::invalid_argument. Also: depthFromRaw is readDepthPng's conversion.
#include "test_io_helpers.hpp"

#include "vdbmap/camera.hpp"
#include "vdbmap/io/errors.hpp"
#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/io/png_io.hpp"
#include "vdbmap/io/point_cloud_io.hpp"
#include "vdbmap/io/sensor_info.hpp"
#include "vdbmap/io/tum_trajectory.hpp"
#include "vdbmap/map_file.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <catch2/catch.hpp>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

using namespace vdbmap;
using vdbmap::test::sharedData;
using vdbmap::test::TempDir;
using vdbmap::test::writeText;

namespace {

/// Requires `fn` to throw vdbmap::FileError whose message names `file`.
void requireFileError(const std::function<void()>& fn, const std::string& file) {
  bool thrown = false;
  try {
    fn();
  } catch (const vdbmap::FileError& e) {
    thrown = true;
    INFO("message: " << e.what());
    CHECK(std::string(e.what()).find(file) != std::string::npos);
  }
  CHECK(thrown);
}

}  // namespace

TEST_CASE("every reader reports a missing file as vdbmap::FileError naming it", "[io][errors]") {
  TempDir dir;
  const auto missing = [&](const std::string& name) { return (dir / name).string(); };
  requireFileError([&] { io::readDepthPng(missing("a.png"), 0.001); }, "a.png");
  requireFileError([&] { io::readPointCloud(missing("b.ply")); }, "b.ply");
  requireFileError([&] { io::readTriangleMesh(missing("c.obj")); }, "c.obj");
  requireFileError([&] { io::readTumTrajectory(missing("d.txt")); }, "d.txt");
  requireFileError([&] { io::readSensorJson(missing("sensor.json")); }, "sensor.json");
  requireFileError([&] { io::openDataset(missing("no_log")); }, "no_log");
  requireFileError([&] { TsdfVolume::load(missing("map.vdb")); }, "map.vdb");
  requireFileError([&] { readTsdfGrid(missing("map2.vdb")); }, "map2.vdb");
}

TEST_CASE("malformed content is an vdbmap::FileError naming the file and line", "[io][errors]") {
  TempDir dir;
  writeText(dir / "traj.txt", "0.0 1 2 3 0 0 0 1\n1.0 1 2 three 0 0 0 1\n");
  requireFileError([&] { io::readTumTrajectory(dir / "traj.txt"); }, "traj.txt:2");
  writeText(dir / "sensor.json", "{\"kind\": \"depth\", ");
  requireFileError([&] { io::readSensorJson(dir / "sensor.json"); }, "sensor.json");
  writeText(dir / "not.vdb", "not an OpenVDB file");
  requireFileError([&] { TsdfVolume::load(dir / "not.vdb"); }, "not.vdb");
  SECTION("writing into a missing folder") {
    requireFileError([&] { TsdfVolume().save(dir / "missing" / "map.vdb"); }, "map.vdb");
    requireFileError([&] { io::writePointCloud(dir / "missing" / "p.bin", {}); }, "p.bin");
  }
}

TEST_CASE("a bad frame is a FileError too, and bad parameters stay invalid_argument", "[io][errors]") {
  TempDir dir;
  writeText(dir / "log" / "sensor.json",
            R"({"kind": "depth", "width": 4, "height": 3, "fx": 5, "fy": 5, "cx": 2, "cy": 1.5, "depth_scale": 0.001})");
  writeText(dir / "log" / "frames.csv", "timestamp,file,tx,ty,tz,qx,qy,qz,qw\n0.5,depth/missing.png,0,0,0,0,0,0,1\n");
  const auto source = io::openDataset(dir / "log");
  REQUIRE(source->size() == 1);
  requireFileError([&] { source->load(0); }, "missing.png");
  CHECK_THROWS_AS(source->load(0), io::BadFrameError);
  CHECK_THROWS_AS(io::readDepthPng(dir / "x.png", -1.0), std::invalid_argument);
}

TEST_CASE("depthFromRaw converts raw units exactly as readDepthPng does", "[io][png]") {
  const auto file = sharedData("7scenes_redkitchen_tsdf_fusion_python/depth/frame-000000.depth.png");
  const io::PngImage raw = io::readPng(file);
  const std::vector<std::uint16_t> samples(raw.samples.begin(), raw.samples.end());
  for (std::uint16_t invalid : {std::uint16_t(0), std::uint16_t(65535)}) {
    const DepthImage expected = io::readDepthPng(file, 0.001, invalid);
    const DepthImage got = depthFromRaw(raw.width, raw.height, samples.data(), 0.001, invalid);
    REQUIRE(got.width == expected.width);
    REQUIRE(got.height == expected.height);
    CHECK(got.depth_m == expected.depth_m);  // bit for bit
  }
  CHECK_THROWS_WITH(depthFromRaw(2, 2, samples.data(), 0.0), Catch::Contains("depth_scale"));
  CHECK_THROWS_WITH(depthFromRaw(-1, 2, samples.data(), 0.001), Catch::Contains("size"));
}
