// Inputs the fuzz targets (fuzz/, docs/fuzzing.md) found to crash a reader or to reach undefined
// behaviour, each now refused with a FileError that names the file and the problem. The raw
// crashers stay under fuzz/regressions/<target>/ and are replayed by the fuzz_replay_* tests.
#include "test_io_helpers.hpp"

#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/io/ros_bag.hpp"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>

using vdbmap::test::TempDir;
using vdbmap::test::writeText;

namespace {

std::string floats(std::initializer_list<float> values) {
  std::string bytes;
  for (const float v : values) {
    char b[4];
    std::memcpy(b, &v, 4);  // the tests' hosts are little endian, as the header below says
    bytes.append(b, 4);
  }
  return bytes;
}

// One bag header field, "name=value" after its uint32 length.
std::string bagField(const std::string& name, const std::string& value) {
  const std::string field = name + "=" + value;
  const auto n = std::uint32_t(field.size());
  return std::string(reinterpret_cast<const char*>(&n), 4) + field;
}

std::string le32(std::uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); }
std::string le64(std::uint64_t v) { return std::string(reinterpret_cast<const char*>(&v), 8); }

}  // namespace

TEST_CASE("a bag whose record declares a 4 GiB header is refused before rosbag_storage allocates it") {
  if (!vdbmap::io::rosBagSupport()) {
    std::printf("skipped: this build reads no ROS bags\n");
    std::exit(77);
  }
  TempDir dir;
  // "#ROSBAG V2.0", a file header record whose index points at the next record, and that record
  // declaring a header of 0xffffffff bytes (rosbag_storage used to allocate them at once).
  const std::string magic = "#ROSBAG V2.0\n";
  std::string header = bagField("op", "\x03") + bagField("conn_count", le32(1)) + bagField("chunk_count", le32(0));
  const std::uint64_t index_pos = magic.size() + 4 + (header.size() + bagField("index_pos", le64(0)).size()) + 4;
  header += bagField("index_pos", le64(index_pos));
  const std::string bag = magic + le32(std::uint32_t(header.size())) + header + le32(0) + le32(0xffffffffu) + "op=\x07";
  writeText(dir / "hostile.bag", bag);
  VDBMAP_REQUIRE_THROWS_MENTIONING(vdbmap::io::inspectRosBag(dir / "hostile.bag"), "hostile.bag",
                                   "record header length 4294967295", "record at byte " + std::to_string(index_pos));
  VDBMAP_REQUIRE_THROWS_MENTIONING(vdbmap::io::openRosBag(dir / "hostile.bag"), "hostile.bag",
                                   "record header length 4294967295");
}

TEST_CASE("an OFF face whose vertex count is INT64_MAX is refused without overflowing the count check") {
  TempDir dir;
  writeText(dir / "big.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n9223372036854775807 0 1 2\n");
  VDBMAP_REQUIRE_THROWS_MENTIONING(vdbmap::io::readTriangleMesh(dir / "big.off"), "big.off:6",
                                   "face lists 3 indices, expected 9223372036854775807");
}

TEST_CASE("a binary PLY face whose float vertex index is out of range, NaN or fractional is refused before conversion") {
  TempDir dir;
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar float vertex_indices\nend_header\n";
  const std::string vertices = floats({0, 0, 0, 1, 0, 0, 0, 1, 0});
  for (const float bad : {1e30f, -1e30f, std::nanf(""), 1.5f, 3.0f}) {
    INFO("index " << bad);
    writeText(dir / "face.ply", header + vertices + std::string(1, '\3') + floats({bad, 0, 1}));
    VDBMAP_REQUIRE_THROWS_MENTIONING(vdbmap::io::readTriangleMesh(dir / "face.ply"), "face.ply", "face number 0",
                                     "but there are 3 vertices");
  }
  // Float indices that are whole numbers in range still read.
  writeText(dir / "face.ply", header + vertices + std::string(1, '\3') + floats({2, 0, 1}));
  const vdbmap::TriangleMesh mesh = vdbmap::io::readTriangleMesh(dir / "face.ply");
  REQUIRE(mesh.triangles.size() == 1);
  CHECK(mesh.triangles[0] == Eigen::Vector3i(2, 0, 1));
}

TEST_CASE("a 7-Scenes frame number too large for 64 bits is refused naming the file, not thrown as out_of_range") {
  TempDir dir;
  writeText(dir / "frame-99999999999999999999.depth.png", "x");
  VDBMAP_REQUIRE_THROWS_MENTIONING(vdbmap::io::openDataset(dir.path()), "frame-99999999999999999999.depth.png",
                                   "frame number '99999999999999999999'");
}

TEST_CASE("a Replica camera whose image width is not an integer in range is refused before conversion") {
  TempDir dir;
  writeText(dir / "traj.txt", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n");
  writeText(dir / "results" / "depth000000.png", "x");
  for (const char* w : {"1e300", "-5", "640.5", "0"}) {
    INFO("w = " << w);
    writeText(dir / "cam_params.json", std::string("{\"camera\": {\"w\": ") + w +
                                           ", \"h\": 480, \"fx\": 600, \"fy\": 600, \"cx\": 320, \"cy\": 240, "
                                           "\"scale\": 6553.5}}");
    VDBMAP_REQUIRE_THROWS_MENTIONING(vdbmap::io::openDataset(dir.path()), "cam_params.json",
                                     "\"w\" must be an integer in [1, 1000000]");
  }
}

TEST_CASE("a JSON number beyond double's range in sensor.json or cam_params.json is refused as invalid JSON") {
  // nlohmann::json reports "1e1000" with out_of_range, not parse_error: both are refusals.
  TempDir dir;
  writeText(dir / "log" / "sensor.json", "{\"kind\": \"depth\", \"width\": 1e1000}");
  writeText(dir / "log" / "frames.csv", "timestamp,file,tx,ty,tz,qx,qy,qz,qw\n");
  VDBMAP_REQUIRE_THROWS_MENTIONING(vdbmap::io::openDataset(dir / "log"), "sensor.json", "invalid JSON", "1e1000");
  writeText(dir / "replica" / "cam_params.json", "{\"camera\": {\"w\": 1e1000}}");
  writeText(dir / "replica" / "traj.txt", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n");
  writeText(dir / "replica" / "results" / "depth000000.png", "x");
  VDBMAP_REQUIRE_THROWS_MENTIONING(vdbmap::io::openDataset(dir / "replica"), "cam_params.json", "invalid JSON");
}
