// TUM trajectories: write/read round trip, comments, and malformed lines naming file and line.
#include "test_io_helpers.hpp"

#include "vdbmap/io/tum_trajectory.hpp"

#include <Eigen/Geometry>

using vdbmap::io::readTumTrajectory;
using vdbmap::io::StampedPose;
using vdbmap::test::TempDir;
using vdbmap::test::writeText;

TEST_CASE("TUM trajectory round trip", "[io][tum]") {
  TempDir dir;
  std::vector<StampedPose> poses;
  for (int i = 0; i < 20; ++i) {
    StampedPose p;
    p.timestamp_s = 1305031102.175304 + 0.033 * i;
    p.T_W_S = Eigen::Translation3d(0.1 * i, -2.0 + i, 0.5) *
              Eigen::AngleAxisd(0.3 * i, Eigen::Vector3d(1, 2, 3).normalized());
    poses.push_back(p);
  }
  vdbmap::io::writeTumTrajectory(dir / "gt.txt", poses);
  const std::vector<StampedPose> back = readTumTrajectory(dir / "gt.txt");
  REQUIRE(back.size() == poses.size());
  constexpr double kTimeTolerance_s = 1e-6;  // 6 decimals written
  constexpr double kPoseTolerance = 1e-7;    // 9 significant digits written
  for (std::size_t i = 0; i < poses.size(); ++i) {
    CHECK(std::abs(back[i].timestamp_s - poses[i].timestamp_s) < kTimeTolerance_s);
    CHECK((back[i].T_W_S.matrix() - poses[i].T_W_S.matrix()).cwiseAbs().maxCoeff() < kPoseTolerance);
  }
}

TEST_CASE("TUM trajectory reader rejects bad lines naming file and line", "[io][tum][bad-input]") {
  TempDir dir;
  const std::string ok = "# comment\n\n1.0 0 0 0 0 0 0 1\n";
  SECTION("missing") { VDBMAP_REQUIRE_THROWS_MENTIONING(readTumTrajectory(dir / "x.txt"), "x.txt", "no such file"); }
  SECTION("too few columns") {
    writeText(dir / "t.txt", ok + "2.0 0 0 0 0 0 1\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readTumTrajectory(dir / "t.txt"), "t.txt:4:", "8 numbers");
  }
  SECTION("NaN") {
    writeText(dir / "t.txt", ok + "2.0 0 nan 0 0 0 0 1\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readTumTrajectory(dir / "t.txt"), "t.txt:4:", "non-finite");
  }
  SECTION("non-unit quaternion") {
    writeText(dir / "t.txt", ok + "2.0 0 0 0 0 0 0.5 0.5\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readTumTrajectory(dir / "t.txt"), "t.txt:4:", "quaternion norm");
  }
  SECTION("timestamps out of order") {
    writeText(dir / "t.txt", ok + "0.5 0 0 0 0 0 0 1\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readTumTrajectory(dir / "t.txt"), "t.txt:4:", "not greater");
    CHECK(readTumTrajectory(dir / "t.txt", /*require_increasing=*/false).size() == 2);
  }
}
