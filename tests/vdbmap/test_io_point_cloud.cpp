// Point clouds: PLY/PCD/bin fixtures (ascii, binary, big endian, odd field layouts), LZF
// binary_compressed PCD, the shared 3DMatch fragments, write/read round trips, bad input.
#include "test_io_helpers.hpp"

#include "vdbmap/io/point_cloud_io.hpp"

#include <cmath>
#include <cstring>

using vdbmap::PointCloud;
using vdbmap::Vec3f;
using vdbmap::io::readPointCloud;
using vdbmap::test::fixture;
using vdbmap::test::TempDir;
using vdbmap::test::writeText;

namespace {

void requireFixturePoints(const PointCloud& p) {
  REQUIRE(p.size() == 5);
  CHECK(p[0] == Vec3f(0.5f, -0.25f, 1.0f));
  CHECK(p[1] == Vec3f(1.5f, 2.0f, 3.25f));
  CHECK(p[2] == Vec3f(-1.0f, 0.0f, 0.125f));
  CHECK(std::isnan(p[3].x()));
  CHECK(std::isnan(p[3].z()));
  CHECK(p[4] == Vec3f(0.0f, 0.0f, 4.0f));
}

}  // namespace

TEST_CASE("readPointCloud reads the point fixtures in every format", "[io][points]") {
  for (const char* name : {"points_ascii.pcd", "points_binary.pcd", "points_binary_be.ply", "points.bin"}) {
    INFO(name);
    requireFixturePoints(readPointCloud(fixture(name)));
  }
  // A mesh's vertices are a point cloud too.
  CHECK(readPointCloud(fixture("cube_ascii.ply")).size() == 8);
}

TEST_CASE("readPointCloud reads LZF binary_compressed PCD", "[io][points]") {
  // Two points with fields x y z, stored field after field once decompressed: x = {1, 2},
  // y = {1, 2}, z = {3, 3}. Compressed by hand: a literal run of 16 bytes (x and y), a literal
  // run of 4 bytes (z0), then a back reference of length 4 at distance 4 (z1).
  float x[2] = {1.0f, 2.0f}, z = 3.0f;
  std::string raw;
  raw.append(reinterpret_cast<const char*>(x), 8);
  raw.append(reinterpret_cast<const char*>(x), 8);
  std::string lzf;
  lzf.push_back(char(16 - 1));  // literal run of 16 bytes
  lzf += raw;
  lzf.push_back(char(4 - 1));   // literal run of 4 bytes (z0)
  lzf.append(reinterpret_cast<const char*>(&z), 4);
  lzf.push_back(char(((4 - 2) << 5) | 0));  // back reference: length 4, distance 4 (offset 3)
  lzf.push_back(char(3));
  const std::uint32_t csize = std::uint32_t(lzf.size()), usize = 24;
  std::string file = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA binary_compressed\n";
  file.append(reinterpret_cast<const char*>(&csize), 4);
  file.append(reinterpret_cast<const char*>(&usize), 4);
  file += lzf;
  TempDir dir;
  writeText(dir / "c.pcd", file);
  const PointCloud p = readPointCloud(dir / "c.pcd");
  REQUIRE(p.size() == 2);
  CHECK(p[0] == Vec3f(1, 1, 3));
  CHECK(p[1] == Vec3f(2, 2, 3));
  // A corrupt back reference (distance beyond the output) is rejected.
  file[file.size() - 1] = char(100);
  writeText(dir / "bad.pcd", file);
  VDBMAP_REQUIRE_THROWS_MENTIONING(readPointCloud(dir / "bad.pcd"), "bad.pcd", "LZF");
}

TEST_CASE("readPointCloud reads the shared 3DMatch fragments (binary PCD)", "[io][points][shared]") {
  using vdbmap::test::sharedData;
  CHECK(readPointCloud(sharedData("open3d_testdata_redwood_tum/Feature/cloud_bin_0.pcd")).size() == 3903);
  const PointCloud p = readPointCloud(sharedData("open3d_testdata_redwood_tum/Feature/cloud_bin_1.pcd"));
  REQUIRE(p.size() == 3458);
  for (const Vec3f& v : p) REQUIRE(v.allFinite());
}

TEST_CASE("writePointCloud then readPointCloud is exact for .ply, .pcd and .bin", "[io][points]") {
  TempDir dir;
  const PointCloud pts = readPointCloud(fixture("points.bin"));
  for (const char* ext : {".ply", ".pcd", ".bin"}) {
    INFO(ext);
    const auto path = dir / (std::string("p") + ext);
    vdbmap::io::writePointCloud(path, pts);
    const PointCloud back = readPointCloud(path);
    REQUIRE(back.size() == pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i)
      CHECK(std::memcmp(back[i].data(), pts[i].data(), sizeof(Vec3f)) == 0);  // bitwise, NaN included
  }
  CHECK_THROWS_AS(vdbmap::io::writePointCloud(dir / "p.xyz", pts), std::invalid_argument);
}

TEST_CASE("readPointCloud rejects malformed point clouds naming file and line", "[io][points][bad-input]") {
  TempDir dir;
  SECTION("missing") { VDBMAP_REQUIRE_THROWS_MENTIONING(readPointCloud(dir / "x.pcd"), "x.pcd", "no such file"); }
  SECTION("PCD ascii with a bad value") {
    writeText(dir / "a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nPOINTS 2\nDATA ascii\n1 2 3\n1 two 3\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readPointCloud(dir / "a.pcd"), "a.pcd:8:", "'two'");
  }
  SECTION("PCD ascii with a missing value") {
    writeText(dir / "a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nPOINTS 2\nDATA ascii\n1 2 3\n1 3\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readPointCloud(dir / "a.pcd"), "a.pcd:8:");
  }
  SECTION("PCD binary truncated") {
    const std::string full = vdbmap::test::readBytes(fixture("points_binary.pcd"));
    writeText(dir / "cut.pcd", full.substr(0, full.size() - 5));
    VDBMAP_REQUIRE_THROWS_MENTIONING(readPointCloud(dir / "cut.pcd"), "cut.pcd", "truncated");
  }
  SECTION("PCD without x y z") {
    writeText(dir / "n.pcd", "FIELDS a b\nSIZE 4 4\nTYPE F F\nWIDTH 1\nDATA ascii\n1 2\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readPointCloud(dir / "n.pcd"), "n.pcd", "x, y and z");
  }
  SECTION("bin with a partial point") {
    writeText(dir / "p.bin", std::string(13, '\0'));
    VDBMAP_REQUIRE_THROWS_MENTIONING(readPointCloud(dir / "p.bin"), "p.bin", "multiple of 12");
  }
  SECTION("PLY binary truncated") {
    const std::string full = vdbmap::test::readBytes(fixture("points_binary_be.ply"));
    writeText(dir / "cut.ply", full.substr(0, full.size() - 3));
    VDBMAP_REQUIRE_THROWS_MENTIONING(readPointCloud(dir / "cut.ply"), "cut.ply", "truncated", "'vertex'");
  }
}
