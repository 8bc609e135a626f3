// The safety layer's pieces: RecentFrames (what the last seconds of depth frames saw free and
// where they saw surfaces) against brute-force references on full-resolution images, and
// RecentObstacleMap (those surfaces as obstacles over another map).
#include "common/quarter_camera.hpp"
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/assume_free_map.hpp"
#include "vdbmap/planner/frontier.hpp"
#include "vdbmap/planner/path_planner.hpp"
#include "vdbmap/planner/recent_frames.hpp"
#include "vdbmap/planner/recent_obstacle_map.hpp"
#include "vdbmap/planner/viewpoint.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <stdexcept>

using namespace vdbmap;
using namespace vdbmap::planner;
using openvdb::Coord;
using openvdb::CoordBBox;
using vdbmap::test::quarterCamera;

namespace {
/// The index RecentFrames keeps holds exactly the voxels of its surface set, with their bounds.
void requireIndexIsSet(RecentFrames& recent) {
  const SurfaceVoxels& set = recent.surfaceVoxels(0.1);  // the size counted already: no recount
  const SurfaceIndex& index = recent.surfaceIndex(0.1);
  REQUIRE(index.size() == set.size());
  CoordBBox bounds;
  for (const auto& [c, n] : set) {
    REQUIRE(index.contains(c));
    bounds.expand(c);
  }
  REQUIRE(index.bounds() == bounds);
  std::size_t held = 0;  // and no voxel besides
  if (!bounds.empty())
    for (auto it = bounds.begin(); it; ++it) held += index.contains(*it);
  REQUIRE(held == set.size());
}

/// Depth of a wall facing the camera at `distance_m` along its optical axis.
DepthImage flatWall(const CameraIntrinsics& K, float distance_m) { return DepthImage(K.width, K.height, distance_m); }

/// Random depths: tiles of 10 x 10 pixels at 1-6 m, each pixel varied by up to 0.2 m, with
/// invalid pixels (0 and NaN) mixed in.
DepthImage randomDepth(const CameraIntrinsics& K, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> tile_depth(1.0f, 6.0f), noise(-0.1f, 0.1f);
  std::uniform_int_distribution<int> kind(0, 39);
  std::vector<float> tiles(std::size_t((K.width / 10 + 1) * (K.height / 10 + 1)));
  for (float& z : tiles) z = tile_depth(rng);
  DepthImage d(K.width, K.height);
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const int k = kind(rng);
      const float z = tiles[std::size_t((v / 10) * (K.width / 10 + 1) + u / 10)] + noise(rng);
      d.at(u, v) = k == 0 ? 0.0f : k == 1 ? std::nanf("") : z;
    }
  return d;
}

/// Brute force of seesFree for one frame: p projects into a block whose every valid pixel has
/// depth >= z + margin, with at least one valid pixel, and z within the range.
bool bruteSeesFree(const DepthImage& depth, const CameraIntrinsics& K, const Pose3d& T_W_S, const RecentFramesConfig& c,
                   const Vec3d& p_W) {
  const Vec3d p = T_W_S.inverse() * p_W;
  if (!(p.z() > 0.0 && p.z() <= c.max_range_m)) return false;
  const double u = K.fx * p.x() / p.z() + K.cx, v = K.fy * p.y() / p.z() + K.cy;
  const int bu = int(std::floor((u + 0.5) / c.pool_px)), bv = int(std::floor((v + 0.5) / c.pool_px));
  if (u + 0.5 < 0.0 || v + 0.5 < 0.0 || bu * c.pool_px >= K.width || bv * c.pool_px >= K.height) return false;
  bool any = false;
  for (int y = bv * c.pool_px; y < std::min(K.height, (bv + 1) * c.pool_px); ++y)
    for (int x = bu * c.pool_px; x < std::min(K.width, (bu + 1) * c.pool_px); ++x) {
      const float d = depth.at(x, y);
      if (!(d > 0.0f) || !std::isfinite(d)) continue;
      any = true;
      if (p.z() + c.free_margin_m > double(d)) return false;
    }
  return any;
}
}  // namespace

TEST_CASE("RecentFramesConfig::validate names the field", "[planner][safety]") {
  RecentFramesConfig c;
  CHECK_NOTHROW(c.validate());
  c.pool_px = 0;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("RecentFramesConfig.pool_px"));
  c = {};
  c.window_s = 0.0;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("RecentFramesConfig.window_s"));
  c = {};
  c.free_margin_m = -1.0;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("RecentFramesConfig.free_margin_m"));
  c = {};
  c.dense_s = 0.0;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("RecentFramesConfig.dense_s"));
  c = {};
  c.sparse_period_s = -0.5;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("RecentFramesConfig.sparse_period_s"));
}

TEST_CASE("A depth image not of the camera's size is refused, naming both sizes, and nothing is kept",
          "[planner][safety][hostile]") {
  const CameraIntrinsics K = quarterCamera();
  RecentFrames frames;
  frames.add(0.0, DepthImage(K.width, K.height, 2.0f), K, Pose3d::Identity());
  const DepthImage wrong(K.width + 1, K.height, 2.0f);
  const std::string sizes = std::to_string(K.width + 1) + "x" + std::to_string(K.height);
  CHECK_THROWS_WITH(frames.add(0.1, wrong, K, Pose3d::Identity()),
                    Catch::Contains("RecentFrames::add") && Catch::Contains(sizes));
  CHECK(frames.frameTimes() == std::vector<double>{0.0});
}

TEST_CASE("A wall 3 m ahead is seen free up to free_margin_m before it, never behind it or outside the view",
          "[planner][safety]") {
  const CameraIntrinsics K = quarterCamera();
  RecentFrames recent;                                                     // margin 0.15 m, range 4.5 m
  CHECK_FALSE(recent.seesFree(Vec3d(1, 0, 0)));                            // nothing seen yet
  recent.add(0.0, flatWall(K, 3.0f), K, lookingPose(Vec3d::Zero(), 0.0));  // looking along +x
  CHECK(recent.seesFree(Vec3d(1.0, 0.0, 0.0)));
  CHECK(recent.seesFree(Vec3d(2.84, 0.5, 0.3)));
  CHECK_FALSE(recent.seesFree(Vec3d(2.86, 0.0, 0.0)));  // within the margin of the wall
  CHECK_FALSE(recent.seesFree(Vec3d(3.5, 0.0, 0.0)));   // behind it
  CHECK_FALSE(recent.seesFree(Vec3d(1.0, 2.0, 0.0)));   // outside the 80 deg field of view
  CHECK_FALSE(recent.seesFree(Vec3d(-1.0, 0.0, 0.0)));  // behind the camera
  // Beyond the trusted range nothing is seen free, even in front of a far wall.
  RecentFrames far;
  far.add(0.0, flatWall(K, 30.0f), K, lookingPose(Vec3d::Zero(), 0.0));
  CHECK(far.seesFree(Vec3d(4.4, 0.0, 0.0)));
  CHECK_FALSE(far.seesFree(Vec3d(4.6, 0.0, 0.0)));
}

TEST_CASE("seesFree equals a brute force over the full-resolution pixels of each frame, and of the frames since a time",
          "[planner][safety]") {
  const CameraIntrinsics K = quarterCamera();
  for (const int pool : {1, 3, 4, 7}) {
    RecentFramesConfig c;
    c.pool_px = pool;
    c.window_s = 100.0;
    RecentFrames recent(c);
    std::vector<DepthImage> images;
    std::vector<Pose3d> poses;
    for (int f = 0; f < 3; ++f) {
      images.push_back(randomDepth(K, std::uint32_t(17 * pool + f)));
      poses.push_back(lookingPose(Vec3d(0.3 * f, -0.2 * f, 1.0), 0.7 * f, 0.1 * f));
      recent.add(double(f), images.back(), K, poses.back());
    }
    std::mt19937 rng{std::uint32_t(pool)};
    std::uniform_real_distribution<double> coord(-4.0, 4.0);
    int free = 0;
    for (int i = 0; i < 20000; ++i) {
      const Vec3d p(coord(rng), coord(rng), 1.0 + 0.3 * coord(rng));
      bool expected = false, expected_since_1 = false;  // by every frame; by those captured at t >= 1 s
      for (int f = 0; f < 3; ++f) {
        const bool sees = bruteSeesFree(images[f], K, poses[f], c, p);
        expected = expected || sees;
        expected_since_1 = expected_since_1 || (f >= 1 && sees);
      }
      free += expected;
      INFO("pool " << pool << " point " << p.transpose());
      REQUIRE(recent.seesFree(p) == expected);
      REQUIRE(recent.seesFree(p, 1.0) == expected_since_1);
    }
    CHECK(free > 1000);  // the comparison covered both answers
  }
}

TEST_CASE("Frames older than the window are forgotten, with their surface voxels", "[planner][safety]") {
  const CameraIntrinsics K = quarterCamera();
  RecentFramesConfig c;
  c.window_s = 1.0;
  RecentFrames recent(c);
  recent.add(0.0, flatWall(K, 3.0f), K, lookingPose(Vec3d::Zero(), 0.0));       // looks along +x
  recent.add(0.5, flatWall(K, 2.0f), K, lookingPose(Vec3d::Zero(), M_PI / 2));  // along +y
  CHECK(recent.size() == 2);
  const std::size_t both = recent.surfaceVoxels(0.1).size();
  CHECK(recent.seesFree(Vec3d(1, 0, 0)));
  recent.add(1.2, flatWall(K, 2.0f), K, lookingPose(Vec3d::Zero(), M_PI / 2));
  CHECK(recent.size() == 2);  // the first is 1.2 s old
  CHECK_FALSE(recent.seesFree(Vec3d(1, 0, 0)));
  CHECK(recent.seesFree(Vec3d(0, 1, 0)));
  // Only the wall at y = 2 m is left: every surface voxel is in its plane.
  const SurfaceVoxels& voxels = recent.surfaceVoxels(0.1);
  CHECK(voxels.size() < both);
  for (const auto& [ijk, n] : voxels) {
    CHECK(ijk.y() == 20);
    CHECK(n == 2);  // both frames at y = 2 m saw it
  }
  recent.clear();
  CHECK(recent.empty());
  CHECK(recent.surfaceVoxels(0.1).empty());
}

TEST_CASE("A long window keeps every frame of the last dense_s and older ones sparse_period_s apart, counted exactly",
          "[planner][safety]") {
  const CameraIntrinsics K = quarterCamera();
  RecentFramesConfig c;
  c.window_s = 20.0;
  c.dense_s = 4.0;
  c.sparse_period_s = 0.5;
  c.newer_free_clears = false;  // the kept frames' counts alone (clearing: the next test)
  RecentFrames recent(c);
  const double period_s = 1.0 / 15.0;  // the simulator's camera rate
  std::vector<DepthImage> images;
  std::vector<Pose3d> poses;
  for (int f = 0; f < 450; ++f) {  // 30 s: the window is full and has moved on
    images.push_back(randomDepth(K, std::uint32_t(f % 7)));
    poses.push_back(lookingPose(Vec3d(0.02 * f, 0.0, 1.0), 0.01 * f));
    recent.add(f * period_s, images.back(), K, poses.back());
    if (f == 100) recent.surfaceVoxels(0.1);  // counted from here on, incrementally
  }
  const double now = 449 * period_s;
  const std::vector<double> kept = recent.frameTimes();
  REQUIRE(kept.size() == recent.size());
  REQUIRE(std::is_sorted(kept.begin(), kept.end()));
  CHECK(kept.front() >= now - c.window_s);
  std::size_t dense = 0;
  for (int f = 0; f < 450; ++f)  // every frame of the last dense_s is kept
    if (f * period_s >= now - c.dense_s) {
      ++dense;
      CHECK(std::find(kept.begin(), kept.end(), f * period_s) != kept.end());
    }
  for (std::size_t i = 1; i < kept.size() && kept[i] < now - c.dense_s; ++i) {
    CHECK(kept[i] - kept[i - 1] >= c.sparse_period_s);            // thinned
    CHECK(kept[i] - kept[i - 1] < c.sparse_period_s + period_s);  // and no more than that
  }
  CHECK(kept.size() - dense <= std::size_t((c.window_s - c.dense_s) / c.sparse_period_s) + 1);
  // The surface voxels are what the kept frames alone make: every dropped frame was taken out.
  RecentFramesConfig all = c;
  all.window_s = all.dense_s = 600.0;
  RecentFrames reference(all);
  for (int f = 0; f < 450; ++f)
    if (std::find(kept.begin(), kept.end(), f * period_s) != kept.end())
      reference.add(f * period_s, images[std::size_t(f)], K, poses[std::size_t(f)]);
  REQUIRE(reference.size() == kept.size());
  CHECK(recent.surfaceVoxels(0.1) == reference.surfaceVoxels(0.1));
  requireIndexIsSet(recent);
}

TEST_CASE("A surface voxel counts each kept frame that saw it until a newer frame, kept or thinned, saw it free",
          "[planner][safety]") {
  const CameraIntrinsics K = quarterCamera();
  RecentFramesConfig c;
  c.window_s = 12.0;
  c.dense_s = 3.0;
  c.sparse_period_s = 0.5;
  RecentFrames recent(c);
  recent.surfaceVoxels(0.1);  // counted from the first frame on
  const double period_s = 1.0 / 15.0;
  constexpr int kFrames = 300;  // 20 s: frames expire and are thinned
  // Brute force, per frame alone: its surface voxels, and what it sees free.
  RecentFramesConfig alone = c;
  alone.window_s = alone.dense_s = 600.0;
  alone.newer_free_clears = false;
  std::vector<RecentFrames> frames(kFrames, RecentFrames(alone));
  for (int f = 0; f < kFrames; ++f) {
    const DepthImage depth = randomDepth(K, std::uint32_t(f % 5));
    const Pose3d pose = lookingPose(Vec3d(0.03 * f, 0.01 * f, 1.0), 0.02 * f);
    recent.add(f * period_s, depth, K, pose);
    frames[std::size_t(f)].add(f * period_s, depth, K, pose);
  }
  // A voxel's count: the kept frames that saw a surface in it after the last frame that saw it
  // free, its centre and its eight corners (a frame's own free view of a voxel it saw a surface
  // in does not clear it).
  const auto seesWhole = [](const RecentFrames& frame, const Coord& ijk) {
    for (int corner = -1; corner < 8; ++corner) {
      const Vec3d offset = corner < 0
                               ? Vec3d::Zero()
                               : Vec3d(corner & 1 ? 0.05 : -0.05, corner & 2 ? 0.05 : -0.05, corner & 4 ? 0.05 : -0.05);
      if (!frame.seesFree(voxelCenterOf(ijk, 0.1) + offset)) return false;
    }
    return true;
  };
  const std::vector<double> kept = recent.frameTimes();
  SurfaceVoxels expected, all_kept;
  std::map<Coord, int> last_free;
  for (int f = 0; f < kFrames; ++f) {
    if (std::find(kept.begin(), kept.end(), f * period_s) == kept.end()) continue;
    for (const auto& [ijk, n] : frames[std::size_t(f)].surfaceVoxels(0.1)) {
      ++all_kept[ijk];
      if (!last_free.count(ijk)) {
        last_free[ijk] = -1;
        for (int g = kFrames - 1; g >= 0; --g)
          if (seesWhole(frames[std::size_t(g)], ijk)) {
            last_free[ijk] = g;
            break;
          }
      }
      if (f >= last_free[ijk]) ++expected[ijk];
    }
  }
  CHECK(recent.surfaceVoxels(0.1) == expected);
  requireIndexIsSet(recent);
  CHECK(expected.size() + 100 < all_kept.size());  // clearing took effect
}

TEST_CASE(
    "A door jamb kept where an earlier frame's drift put it no longer narrows the door once a newer frame "
    "sees through it",
    "[planner][safety]") {
  // A wall at x = 2 m with a door 1 m wide (|y| < 0.5 m, up to z = 2 m), a far wall at x = 4 m.
  // The camera stands at (0, 0, 1) looking along +x; its second frame is the same image under an
  // estimate that drifted 0.6 m in y since the first (about 15 s at s3).
  const CameraIntrinsics K = quarterCamera();
  const Pose3d truth = lookingPose(Vec3d(0.0, 0.0, 1.0), 0.0);
  DepthImage depth(K.width, K.height);
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const Vec3d ray = truth.linear() * Vec3d((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);  // depth 1 along it
      const Vec3d at_wall = truth.translation() + ray * (2.0 / ray.x());
      const bool door = std::abs(at_wall.y()) < 0.5 && at_wall.z() < 2.0;
      depth.at(u, v) = float((door ? 4.0 : 2.0) / ray.x());
    }
  Pose3d drifted = truth;
  drifted.translation().y() += 0.6;
  // Only the space in front of the wall, y in [-0.6, 1.4], is free in the base map: a path from
  // the room to the far side must pass the door.
  DenseMap base(0.1, CoordBBox(Coord(-5, -10, -5), Coord(45, 20, 25)));
  base.fillWorld(Eigen::AlignedBox3d(Vec3d(0.0, -0.6, 0.2), Vec3d(3.5, 1.4, 2.4)), Occupancy::Free);
  const Vec3d start(0.5, 0.6, 1.0), goal(3.0, 0.6, 1.0);  // through the door as the newest frame sees it
  for (const bool clears : {false, true}) {
    CAPTURE(clears);
    RecentFramesConfig c;
    c.newer_free_clears = clears;
    RecentFrames recent(c);
    recent.add(0.0, depth, K, truth);
    recent.add(0.5, depth, K, drifted);
    const SurfaceVoxels& surface = recent.surfaceVoxels(0.1);
    // The first frame's jamb, 0.5-0.8 m in y, lies in the door the newest frame sees (0.1 to 1.1 m),
    // from z = 0 (the lowest voxels the camera sees whole) to 1.8 m.
    std::size_t in_door = 0;
    for (const auto& [ijk, n] : surface)
      in_door += ijk.x() == 20 && ijk.y() >= 5 && ijk.y() <= 8 && ijk.z() >= 0 && ijk.z() <= 18;
    if (clears)
      CHECK(in_door == 0);
    else
      CHECK(in_door > 10);
    const RecentObstacleMap flight(base, surface);
    CHECK(PathPlanner(flight).plan(start, goal, 1).ok() == clears);
    // The newest frame's own jambs stay: the wall beside the door is no way through.
    CHECK(surface.count(Coord(20, -2, 10)));
    CHECK(surface.count(Coord(20, 12, 10)));
  }
}

TEST_CASE("A ceiling seen at a grazing angle is not cleared by a newer frame that sees it so too",
          "[planner][safety]") {
  // A ceiling at z = 2.23 m, just above a camera at 2.2 m looking along +x at a wall 4.4 m away:
  // the ceiling's voxels (2.15-2.25 m) have their centres level with the camera, so near it the
  // camera sees their centres free (a level ray never meets the ceiling, and the pixel block
  // around it meets the ceiling farther out), while their upper corners lie behind the ceiling.
  // The second frame is taken 0.3 m further back: it keeps each block's nearest point, so it
  // does not hit every voxel the first one hit.
  const CameraIntrinsics K = quarterCamera();
  const auto render = [&](const Pose3d& pose) {
    DepthImage depth(K.width, K.height);
    for (int v = 0; v < K.height; ++v)
      for (int u = 0; u < K.width; ++u) {
        const Vec3d ray = pose.linear() * Vec3d((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);  // depth 1 along it
        const double to_wall = (4.4 - pose.translation().x()) / ray.x();
        const double to_ceiling = ray.z() > 0.0 ? 0.03 / ray.z() : to_wall;
        depth.at(u, v) = float(std::min(to_wall, to_ceiling));
      }
    return depth;
  };
  const Pose3d near = lookingPose(Vec3d(0.0, 0.0, 2.2), 0.0), back = lookingPose(Vec3d(-0.3, 0.0, 2.2), 0.0);
  RecentFrames first, second, both;
  first.add(0.0, render(near), K, near);
  second.add(0.1, render(back), K, back);
  both.add(0.0, render(near), K, near);
  both.add(0.1, render(back), K, back);
  const SurfaceVoxels &seen_first = first.surfaceVoxels(0.1), &seen_second = second.surfaceVoxels(0.1);
  const SurfaceVoxels& seen_both = both.surfaceVoxels(0.1);
  std::size_t centre_seen_free = 0, kept = 0;
  for (const auto& [ijk, n] : seen_first) {
    centre_seen_free += !seen_second.count(ijk) && second.seesFree(voxelCenterOf(ijk, 0.1));
    kept += seen_both.count(ijk);
  }
  CHECK(centre_seen_free >= 5);  // a rule on the centre alone would clear these
  CHECK(kept == seen_first.size());
}

TEST_CASE("Surface voxels hold exactly each block's nearest point within range, and move with shift()",
          "[planner][safety]") {
  const CameraIntrinsics K = quarterCamera();
  RecentFramesConfig c;
  c.pool_px = 4;
  RecentFrames recent(c);
  const DepthImage depth = randomDepth(K, 5);
  const Pose3d T_W_S = lookingPose(Vec3d(0.4, -0.3, 1.2), 0.3, 0.05);
  recent.add(0.0, depth, K, T_W_S);
  // Brute force: each block's nearest valid pixel, back-projected.
  const auto bruteVoxels = [&](const Pose3d& pose) {
    std::set<Coord> voxels;
    for (int bv = 0; bv < K.height / 4; ++bv)
      for (int bu = 0; bu < K.width / 4; ++bu) {
        float d = 0.0f;
        int un = 0, vn = 0;
        for (int y = 4 * bv; y < 4 * bv + 4; ++y)
          for (int x = 4 * bu; x < 4 * bu + 4; ++x) {
            const float z = depth.at(x, y);
            if (z > 0.0f && std::isfinite(z) && (d == 0.0f || z < d)) {
              d = z;
              un = x;
              vn = y;
            }
          }
        if (!(d > 0.0f && d <= c.max_range_m)) continue;
        const Vec3d p = pose * Vec3d((un - K.cx) * d / K.fx, (vn - K.cy) * d / K.fy, d);
        voxels.insert(Coord(int(std::floor(p.x() / 0.1 + 0.5)), int(std::floor(p.y() / 0.1 + 0.5)),
                            int(std::floor(p.z() / 0.1 + 0.5))));
      }
    return voxels;
  };
  const auto voxelsOf = [](const SurfaceVoxels& counted) {
    std::set<Coord> voxels;
    for (const auto& [ijk, n] : counted) voxels.insert(ijk);
    return voxels;
  };
  CHECK(voxelsOf(recent.surfaceVoxels(0.1)) == bruteVoxels(T_W_S));
  // The estimate frame moves: the frame's surfaces move with it.
  Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
  shift.rotate(Eigen::AngleAxisd(0.4, Vec3d::UnitZ()));
  shift.translation() = Vec3d(0.5, -0.2, 0.1);
  recent.shift(shift);
  CHECK(voxelsOf(recent.surfaceVoxels(0.1)) == bruteVoxels(shift * T_W_S));
  requireIndexIsSet(recent);
  // A new voxel size recounts from the stored points.
  CHECK(recent.surfaceVoxels(0.2).size() < bruteVoxels(shift * T_W_S).size());
}

TEST_CASE("RecentObstacleMap reads recent surface voxels occupied and everything else as its base",
          "[planner][safety]") {
  const DenseMap base = planner::test::makeRoom(Eigen::Vector3i(20, 20, 10));
  SurfaceVoxels surface;
  surface[Coord(5, 5, 5)] = 1;  // free in the base
  surface[Coord(6, 5, 5)] = 2;
  surface[Coord(0, 3, 3)] = 1;   // occupied in the base already
  surface[Coord(30, 3, 3)] = 1;  // unknown in the base (outside the room)
  const RecentObstacleMap map(base, surface);
  CHECK(map.voxelSize() == base.voxelSize());
  CHECK(map.knownBounds().isInside(Coord(30, 3, 3)));
  auto reader = map.reader();
  auto base_reader = base.reader();
  const CoordBBox all(Coord(-2), Coord(31, 21, 11));
  for (auto it = all.begin(); it; ++it) {
    const Occupancy expected = surface.count(*it) ? Occupancy::Occupied : base_reader->at(*it);
    REQUIRE(reader->at(*it) == expected);
  }
  // readBox equals at() voxel by voxel, for a box smaller than the set and one larger.
  for (const CoordBBox& box : {CoordBBox(Coord(5, 5, 5), Coord(6, 5, 5)), CoordBBox(Coord(-1), Coord(30, 10, 8))})
    planner::test::requireReadBoxMatchesAt(*reader, box);
  CHECK(&map.sightMap() == &base.sightMap());

  // nearSurface: some surface voxel's centre within the radius (brute force over the set).
  std::mt19937 rng{11};
  std::uniform_real_distribution<double> coord(0.0, 0.8);
  int near = 0;
  for (int i = 0; i < 2000; ++i) {
    const Vec3d p(coord(rng), coord(rng), coord(rng));
    const double r = 0.05 + 0.1 * (i % 4);
    bool expected = false;
    for (const auto& [ijk, n] : surface) expected = expected || (map.voxelCenter(ijk) - p).norm() <= r;
    near += expected;
    REQUIRE(map.nearSurface(p, r) == expected);
    // surfaceDistance: the nearest surface voxel centre's distance, capped at its max.
    double nearest = r;
    for (const auto& [ijk, n] : surface) nearest = std::min(nearest, (map.voxelCenter(ijk) - p).norm());
    REQUIRE(map.surfaceDistance(p, r) == Approx(nearest).margin(1e-12));
  }
  CHECK(near > 100);
  CHECK(near < 1900);

  // Many surface voxels over a box of several blocks of bits in every axis, none a whole number
  // of blocks: each voxel reads occupied exactly when it is in the set.
  SurfaceVoxels scattered;
  std::uniform_int_distribution<int> sx(-7, 29), sy(-3, 25), sz(-2, 18);
  for (int i = 0; i < 600; ++i) scattered[Coord(sx(rng), sy(rng), sz(rng))] = 1;
  const RecentObstacleMap many(base, scattered);
  auto many_reader = many.reader();
  for (auto it = CoordBBox(Coord(-9, -5, -4), Coord(31, 27, 20)).begin(); it; ++it)
    REQUIRE((many_reader->at(*it) == Occupancy::Occupied) ==
            (scattered.count(*it) > 0 || base_reader->at(*it) == Occupancy::Occupied));

  // Surface voxels spread over a box too large for one bit per voxel are looked up instead.
  SurfaceVoxels spread;
  spread[Coord(5, 5, 5)] = 1;
  spread[Coord(1200, 1200, 200)] = 1;
  const RecentObstacleMap sparse(base, spread);
  auto sparse_reader = sparse.reader();
  CHECK(sparse_reader->at(Coord(5, 5, 5)) == Occupancy::Occupied);
  CHECK(sparse_reader->at(Coord(1200, 1200, 200)) == Occupancy::Occupied);
  CHECK(sparse_reader->at(Coord(6, 5, 5)) == Occupancy::Free);
  CHECK(sparse_reader->at(Coord(600, 600, 100)) == Occupancy::Unknown);
}

TEST_CASE("RecentObstacleMap with seen free space reopens what drift closed in the map, and only that",
          "[planner][safety]") {
  // A 4 x 2 x 1.2 m room whose map holds a ghost wall across it at x = 2 m (where drift put a wall
  // seen earlier); the vehicle at x = 0.5 m looks along +x at the real end wall, 3.4 m away.
  DenseMap base = planner::test::makeRoom(Eigen::Vector3i(40, 20, 12));
  for (int y = 1; y <= 18; ++y)
    for (int z = 1; z <= 10; ++z) base.set(Coord(20, y, z), Occupancy::Occupied);
  base.set(Coord(8, 10, 6), Occupancy::Unknown);    // a hole the map never saw, in front of the camera
  base.set(Coord(10, 18, 6), Occupancy::Occupied);  // a ghost voxel outside the field of view
  const CameraIntrinsics K = quarterCamera();
  RecentFrames recent;
  recent.add(0.0, flatWall(K, 3.4f), K, lookingPose(Vec3d(0.5, 1.0, 0.6), 0.0));
  const SurfaceVoxels& surface = recent.surfaceVoxels(base.voxelSize());
  const RecentObstacleMap plain(base, surface), reopened(base, surface, &recent);
  auto plain_reader = plain.reader(), reader = reopened.reader(), base_reader = base.reader();

  // Ahead of the camera, the ghost wall and the hole read free; outside the field of view and
  // behind the end wall they keep the base's state; without seen_free nothing changes.
  CHECK(reader->at(Coord(20, 10, 6)) == Occupancy::Free);
  CHECK(reader->at(Coord(8, 10, 6)) == Occupancy::Free);
  CHECK(plain_reader->at(Coord(20, 10, 6)) == Occupancy::Occupied);
  CHECK(plain_reader->at(Coord(8, 10, 6)) == Occupancy::Unknown);
  CHECK(reader->at(Coord(10, 18, 6)) == Occupancy::Occupied);
  CHECK(reader->at(Coord(39, 10, 6)) == Occupancy::Occupied);
  CHECK(reader->at(Coord(41, 10, 6)) == Occupancy::Unknown);

  // Every voxel: a recent surface is occupied, else what a recent frame saw free within the
  // base's known bounds is free, else the base; readBox agrees with at(). (The flat image sees
  // "through" the room's side walls, into space the base map does not know.)
  const CoordBBox all(Coord(-2), Coord(41, 21, 13));
  std::size_t reopened_voxels = 0;
  for (auto it = all.begin(); it; ++it) {
    const Occupancy b = base_reader->at(*it);
    const bool seen = base.knownBounds().isInside(*it) && recent.seesFree(base.voxelCenter(*it));
    const Occupancy expected =
        surface.count(*it) ? Occupancy::Occupied : (b != Occupancy::Free && seen ? Occupancy::Free : b);
    reopened_voxels += b != Occupancy::Free && expected == Occupancy::Free;
    REQUIRE(reader->at(*it) == expected);
  }
  CHECK(reopened_voxels > 50);  // the ghost wall's part in view, and the hole
  // Boxes beside the seen free space along y or z alone (overlapping it along x) must not write
  // outside themselves: an OpenVDB box iterator checks only its first axis, so iterating an empty
  // intersection visits voxels outside both boxes (this corrupted the heap of office runs).
  const CoordBBox beside_y(Coord(15, -8, 3), Coord(25, -3, 9)), beside_z(Coord(15, 5, -8), Coord(25, 15, -3));
  CHECK(reader->at(Coord(20, 0, 6)) == Occupancy::Free);   // the wall beside beside_y is seen free
  CHECK(reader->at(Coord(20, 10, 0)) == Occupancy::Free);  // and so is the floor above beside_z
  for (const CoordBBox& box : {CoordBBox(Coord(18, 5, 3), Coord(22, 15, 9)), all, beside_y, beside_z})
    planner::test::requireReadBoxMatchesAt(*reader, box);

  // A path across the room: the ghost wall blocks it in the map, the frame seen now reopens it.
  const Vec3d start(0.5, 1.0, 0.6), goal(3.2, 1.0, 0.6);
  CHECK_FALSE(PathPlanner(plain).plan(start, goal, 1).ok());
  const PathResult through = PathPlanner(reopened).plan(start, goal, 1);
  REQUIRE(through.ok());
  CHECK((through.waypoints.back() - goal).norm() < 1e-9);
}

namespace {
/// Voxel states copied out of another map and looked up, with that map's sight map.
class LookedUp : public MapQuery {
 public:
  LookedUp(const MapQuery& from, const CoordBBox& extent)
      : states_(from.voxelSize(), extent), sight_(&from.sightMap()) {
    auto reader = from.reader();
    for (auto it = extent.begin(); it; ++it) states_.set(*it, reader->at(*it));
  }
  double voxelSize() const override { return states_.voxelSize(); }
  CoordBBox knownBounds() const override { return states_.knownBounds(); }
  std::unique_ptr<MapReader> reader() const override { return states_.reader(); }
  const MapQuery& sightMap() const override { return *sight_; }

 private:
  DenseMap states_;
  const MapQuery* sight_;
};
}  // namespace

TEST_CASE("Viewpoints over seen free space, read voxel by voxel, equal those over the same states looked up",
          "[planner][safety][viewpoint]") {
  // The half-known room (a frontier plane at x = 3.9 m) whose map holds a ghost wall at x = 2.5 m
  // with a door; the vehicle at x = 0.5 m sees along +x to 3.9 m, through the ghost.
  DenseMap base = planner::test::halfKnownRoom();
  base.fill(CoordBBox(Coord(25, 1, 1), Coord(25, 58, 28)), Occupancy::Occupied);
  base.fill(CoordBBox(Coord(25, 26, 1), Coord(25, 34, 20)), Occupancy::Free);
  const CameraIntrinsics K = quarterCamera();
  RecentFrames recent;
  recent.add(0.0, flatWall(K, 3.4f), K, lookingPose(Vec3d(0.5, 3.0, 1.5), 0.0));
  const SurfaceVoxels& surface = recent.surfaceVoxels(base.voxelSize());
  const RecentObstacleMap plain(base, surface), reopened(base, surface, &recent);
  // Seen free space is computed per voxel, so reading whole boxes of it does not pay.
  CHECK(plain.boxReadsPay());
  CHECK_FALSE(reopened.boxReadsPay());
  // A wrapper that reads its base's boxes says what its base says.
  CHECK_FALSE(AssumeFreeMap(reopened, {}).boxReadsPay());
  CHECK(AssumeFreeMap(plain, {}).boxReadsPay());

  FrontierMap frontiers;
  frontiers.rebuild(base);
  REQUIRE_FALSE(frontiers.clusters().empty());
  const LookedUp looked_up(reopened, base.extent());
  REQUIRE(looked_up.boxReadsPay());
  const ViewpointConfig params;
  std::size_t total = 0, differ_from_plain = 0;
  for (const FrontierCluster& cluster : frontiers.clusters()) {
    const std::vector<Viewpoint> views = computeViewpoints(cluster, reopened, params),
                                 expected = computeViewpoints(cluster, looked_up, params),
                                 held = computeViewpoints(cluster, plain, params);
    REQUIRE(views.size() == expected.size());
    for (std::size_t i = 0; i < views.size(); ++i) {
      REQUIRE(views[i].position_W == expected[i].position_W);
      REQUIRE(views[i].yaw_rad == expected[i].yaw_rad);
      REQUIRE(views[i].visible_samples == expected[i].visible_samples);
    }
    total += views.size();
    differ_from_plain += views.size() != held.size();
  }
  CHECK(total > 20);
  CHECK(differ_from_plain > 0);  // the reopened ghost wall frees some candidates
}

TEST_CASE(
    "RecentObstacleMap's vertical margin grows the map's obstacles up and down, and seen free space does not undo it",
    "[planner][safety]") {
  // The room and frame of the test above: a ghost wall at x = 2 m that the frame sees free, a
  // ghost voxel outside its view. With a margin of m voxels, a voxel that reads free without it
  // reads occupied when a voxel within m straight above or below reads occupied (as the wrapper
  // without margin reads it: recent surfaces aside, a seen-free ghost grows nothing).
  DenseMap base = planner::test::makeRoom(Eigen::Vector3i(40, 20, 12));
  for (int y = 1; y <= 18; ++y)
    for (int z = 1; z <= 10; ++z) base.set(Coord(20, y, z), Occupancy::Occupied);
  base.set(Coord(10, 18, 6), Occupancy::Occupied);
  base.set(Coord(30, 5, 9), Occupancy::Unknown);  // unknown grows nothing
  const CameraIntrinsics K = quarterCamera();
  RecentFrames recent;
  recent.add(0.0, flatWall(K, 3.4f), K, lookingPose(Vec3d(0.5, 1.0, 0.6), 0.0));
  const SurfaceVoxels& surface = recent.surfaceVoxels(base.voxelSize());
  const RecentObstacleMap none(base, surface, &recent), grown(base, surface, &recent, 2);
  CHECK(grown.verticalMarginVoxels() == 2);
  auto none_reader = none.reader(), reader = grown.reader();
  const CoordBBox all(Coord(-2), Coord(41, 21, 13));
  std::size_t grown_voxels = 0;
  for (auto it = all.begin(); it; ++it) {
    const Occupancy plain = none_reader->at(*it);
    Occupancy expected = plain;
    if (plain == Occupancy::Free && !surface.count(*it))
      for (int k = -2; k <= 2; ++k) {
        const Coord c = (*it).offsetBy(0, 0, k);
        if (!surface.count(c) && none_reader->at(c) == Occupancy::Occupied) expected = Occupancy::Occupied;
      }
    grown_voxels += plain != expected;
    REQUIRE(reader->at(*it) == expected);
  }
  // The floor and ceiling grow by up to two voxels (less where the frame saw them free), the
  // ghost voxel by two above and two below; the seen-free ghost wall not at all.
  CHECK(reader->at(Coord(10, 18, 4)) == Occupancy::Occupied);
  CHECK(reader->at(Coord(10, 18, 8)) == Occupancy::Occupied);
  CHECK(reader->at(Coord(10, 18, 3)) == Occupancy::Free);
  CHECK(reader->at(Coord(20, 10, 6)) == Occupancy::Free);
  CHECK(reader->at(Coord(30, 5, 8)) == Occupancy::Free);
  CHECK(grown_voxels > 38 * 18);  // more than one layer over the room
  for (const CoordBBox& box :
       {CoordBBox(Coord(18, 5, 3), Coord(22, 15, 9)), all, CoordBBox(Coord(9, 17, 5), Coord(9, 17, 5)),
        CoordBBox(Coord(15, -8, 3), Coord(25, -3, 9)), CoordBBox(Coord(15, 5, -8), Coord(25, 15, -3))})
    planner::test::requireReadBoxMatchesAt(*reader, box);
  CHECK_THROWS_AS(RecentObstacleMap(base, surface, &recent, -1), std::invalid_argument);
  CHECK_THROWS_AS(RecentObstacleMap(base, surface, &recent, 101), std::invalid_argument);
}

TEST_CASE("Under a beam that drift holds too high in the map, the vertical margin keeps paths clear of the true beam",
          "[planner][safety]") {
  // A 4 x 2 x 2.5 m room with a beam across it over x 1.5-2.5 m. The true beam's underside is at
  // 1.85 m; drift left the map holding it 0.2 m higher (voxels 21-23, underside at 2.05 m), and
  // the camera, looking ahead, never sees straight up. Paths keep clearance_m (0.3 m) from the
  // map; the vehicle is 0.2 m.
  constexpr double kVehicleRadiusM = 0.2, kTrueUnderside_m = 1.85;
  DenseMap base = planner::test::makeRoom(Eigen::Vector3i(40, 20, 25));
  base.fill(CoordBBox(Coord(15, 1, 21), Coord(25, 18, 23)), Occupancy::Occupied);
  const SurfaceVoxels no_surface;
  const RecentObstacleMap as_held(base, no_surface), with_margin(base, no_surface, nullptr, 2);
  const auto trueClearanceUnderBeam = [&](const std::vector<Vec3d>& path) {
    double least = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i + 1 < path.size(); ++i)
      for (double s = 0.0; s <= 1.0; s += 0.01) {
        const Vec3d p = path[i] + s * (path[i + 1] - path[i]);
        if (p.x() >= 1.5 && p.x() <= 2.5) least = std::min(least, kTrueUnderside_m - p.z());
      }
    return least;
  };
  // A goal under the beam as high as the map allows: the map as held lets the vehicle into the
  // true beam; with the margin that goal is refused, and one 0.2 m lower is clear of it.
  const Vec3d start(0.5, 1.0, 1.2), high_goal(2.0, 1.0, 1.75), lower_goal(2.0, 1.0, 1.55);
  const PathResult into = PathPlanner(as_held).plan(start, high_goal, 1);
  REQUIRE(into.ok());
  CHECK(trueClearanceUnderBeam(into.waypoints) < kVehicleRadiusM);
  CHECK_FALSE(PathPlanner(with_margin).plan(start, high_goal, 1).ok());
  const PathResult under = PathPlanner(with_margin).plan(start, lower_goal, 1);
  REQUIRE(under.ok());
  CHECK(trueClearanceUnderBeam(under.waypoints) >= kVehicleRadiusM);
}
