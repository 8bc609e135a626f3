// What the camera saw: the voxels of its depth returns at the true poses, against a brute-force
// reference that places every pixel's return; invalid and out-of-range returns mark nothing.
#include "vdbmap/sim/seen_surface.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <set>
#include <tuple>

using namespace vdbmap;
using namespace vdbmap::sim;
using openvdb::Coord;

namespace {
constexpr double kVoxel = 0.1;
constexpr double kMaxRange = 4.5;

/// A camera at (1, 2, 1.5) looking along +x.
Pose3d facingX() { return lookingPose(Vec3d(1.0, 2.0, 1.5), 0.0); }

std::set<std::tuple<int, int, int>> everyPixelsVoxel(const DepthImage& d, const CameraIntrinsics& K, const Pose3d& T) {
  std::set<std::tuple<int, int, int>> out;
  for (int v = 0; v < d.height; ++v)
    for (int u = 0; u < d.width; ++u) {
      const float z = d.at(u, v);
      if (!(z > 0.0f && z <= kMaxRange)) continue;
      const Coord c = planner::voxelOf(T * backProjectPixel(u, v, z, K, 1.0 / K.fx, 1.0 / K.fy).cast<double>(), kVoxel);
      out.emplace(c.x(), c.y(), c.z());
    }
  return out;
}
}  // namespace

TEST_CASE("SeenSurface marks the voxels of the returns, every one within a voxel of a pixel's return",
          "[sim][coverage]") {
  // The simulator's camera (640 x 480, fx 387): every 4th pixel is used at 0.1 m voxels; a wall
  // 3.95 m ahead, slanted so that its returns cross voxel faces at every angle.
  const CameraIntrinsics K;
  DepthImage depth(K.width, K.height);
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) depth.at(u, v) = float(3.0 + 0.002 * u + 0.0005 * v);
  const Pose3d T = facingX();
  SeenSurface seen(kVoxel);
  seen.addFrame(depth, K, T, kMaxRange);
  const auto all = everyPixelsVoxel(depth, K, T);
  REQUIRE(all.size() > 1000);
  const std::unique_ptr<planner::MapReader> r = seen.reader();
  std::size_t marked = 0;
  for (const auto& [x, y, z] : all) {
    bool near = false;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz)
          near = near || r->at(Coord(x + dx, y + dy, z + dz)) == planner::Occupancy::Occupied;
    CHECK(near);
    marked += r->at(Coord(x, y, z)) == planner::Occupancy::Occupied;
  }
  CHECK(seen.seenVoxels() == marked);  // nothing marked that no pixel's return fell in
  CHECK(double(marked) > 0.9 * double(all.size()));
  for (const auto& [x, y, z] : all)
    if (r->at(Coord(x, y, z)) == planner::Occupancy::Occupied) CHECK(seen.knownBounds().isInside(Coord(x, y, z)));
  CHECK(r->at(planner::voxelOf(T.translation(), kVoxel)) == planner::Occupancy::Unknown);  // the free space in front
}

TEST_CASE("SeenSurface leaves out invalid returns and those beyond the range, and refuses bad input",
          "[sim][coverage]") {
  CameraIntrinsics K;
  K.width = 8;
  K.height = 6;
  K.fx = K.fy = 4.0;
  K.cx = 3.5;
  K.cy = 2.5;
  DepthImage depth(K.width, K.height, 0.0f);
  depth.at(0, 0) = std::numeric_limits<float>::quiet_NaN();
  depth.at(1, 0) = float(kMaxRange + 0.01);
  depth.at(2, 0) = -1.0f;
  SeenSurface seen(kVoxel);
  seen.addFrame(depth, K, facingX(), kMaxRange);
  CHECK(seen.seenVoxels() == 0);
  CHECK(seen.knownBounds().empty());
  depth.at(3, 0) = 2.0f;
  seen.addFrame(depth, K, facingX(), kMaxRange);
  CHECK(seen.seenVoxels() == 1);

  CHECK_THROWS_WITH(SeenSurface(0.0), Catch::Contains("voxel_size_m"));
  CHECK_THROWS_WITH(SeenSurface(std::nan("")), Catch::Contains("voxel_size_m"));
  const DepthImage wrong(K.width + 1, K.height);
  CHECK_THROWS_WITH(seen.addFrame(wrong, K, facingX(), kMaxRange), Catch::Contains("9x6") && Catch::Contains("8x6"));
  CHECK_THROWS_WITH(seen.addFrame(depth, K, facingX(), 0.0), Catch::Contains("max_range_m"));
  CHECK(seen.seenVoxels() == 1);  // the refused frames changed nothing
}
