// The planner's map interface: synthetic maps, the TSDF adapter, the assume-free wrapper, the
// per-cycle block cache, and MapProbe's clearance, segment and visibility checks against brute force.
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/assume_free_map.hpp"
#include "vdbmap/planner/cached_map.hpp"
#include "vdbmap/planner/dense_map.hpp"
#include "vdbmap/planner/map_query.hpp"
#include "vdbmap/planner/tsdf_map_query.hpp"
#include "vdbmap/camera.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <catch2/catch.hpp>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <optional>
#include <random>

using namespace vdbmap;
using namespace vdbmap::planner;
using openvdb::Coord;
using openvdb::CoordBBox;

namespace {
/// A 3 x 3 x 1.5 m map at 0.1 m: free with ~8% occupied and ~4% unknown voxels at random (or
/// the given fractions).
DenseMap randomMap(std::uint32_t seed, double occupied = 0.08, double unknown = 0.04) {
  DenseMap map(0.1, CoordBBox(Coord(0), Coord(29, 29, 14)));
  map.fill(map.extent(), Occupancy::Free);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (auto it = map.extent().begin(); it; ++it) {
    const double x = u(rng);
    if (x < occupied)
      map.set(*it, Occupancy::Occupied);
    else if (x < occupied + unknown)
      map.set(*it, Occupancy::Unknown);
  }
  return map;
}
}  // namespace

TEST_CASE("DenseMap stores states, is unknown outside its extent and reports known bounds", "[planner][map]") {
  DenseMap map(0.1, CoordBBox(Coord(-5), Coord(5)));
  CHECK(map.knownBounds().empty());
  CHECK(map.get(Coord(0)) == Occupancy::Unknown);
  map.set(Coord(1, 2, 3), Occupancy::Occupied);
  map.fill(CoordBBox(Coord(-2), Coord(-1)), Occupancy::Free);
  CHECK(map.get(Coord(1, 2, 3)) == Occupancy::Occupied);
  CHECK(map.get(Coord(-2, -1, -2)) == Occupancy::Free);
  CHECK(map.get(Coord(100)) == Occupancy::Unknown);
  CHECK(map.knownBounds() == CoordBBox(Coord(-2), Coord(1, 2, 3)));
  CHECK_THROWS_AS(map.set(Coord(6), Occupancy::Free), std::out_of_range);
  // World boxes select voxels by centre: [0.05, 0.25] holds the centres 0.1 and 0.2.
  const CoordBBox b = map.voxelsIn(Eigen::AlignedBox3d(Vec3d::Constant(0.05), Vec3d::Constant(0.25)));
  CHECK(b == CoordBBox(Coord(1), Coord(2)));
  CHECK(map.worldToVoxel(Vec3d(0.049, -0.051, 0.15)) == Coord(0, -1, 2));
}

TEST_CASE("MapProbe::isClear and clearance match brute force", "[planner][map]") {
  const DenseMap map = randomMap(7);
  MapProbe probe(map);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> pos(0.3, 2.6), posz(0.3, 1.1), rad(0.0, 0.35);
  int clear_count = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vec3d p(pos(rng), pos(rng), posz(rng));
    const double r = rad(rng);
    const bool clear = probe.isClear(p, r);
    REQUIRE(clear == test::bruteClear(map, p, r));
    clear_count += clear;
    // clearance(): the distance to the nearest non-free voxel centre (capped).
    const double c = probe.clearance(p, 0.5);
    double brute = map.get(map.worldToVoxel(p)) == Occupancy::Free ? 0.5 : 0.0;
    if (brute > 0.0)
      for (auto it = map.extent().expandBy(6).begin(); it; ++it)  // unknown beyond the extent counts
        if (map.get(*it) != Occupancy::Free) brute = std::min(brute, (map.voxelCenter(*it) - p).norm());
    REQUIRE(c == Approx(brute).margin(1e-12));
  }
  CHECK(clear_count > 100);  // both outcomes are exercised
}

TEST_CASE("MapProbe::isVisible equals a brute-force slab test of every voxel the segment crosses", "[planner][map]") {
  const DenseMap map = randomMap(3);
  MapProbe probe(map);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> pos(0.05, 2.85), posz(0.05, 1.35), len(0.0, 1.0);
  int visible = 0;
  for (int i = 0; i < 4000; ++i) {
    const Vec3d a(pos(rng), pos(rng), posz(rng));
    // Mostly short segments (long ones are nearly always blocked in this clutter).
    const Vec3d b = a + (Vec3d(pos(rng), pos(rng), posz(rng)) - a) * len(rng) * len(rng);
    const bool v = probe.isVisible(a, b);
    REQUIRE(v == test::bruteVisible(map, a, b));
    visible += v;
  }
  CHECK(visible > 200);
}

TEST_CASE("MapProbe::firstNotFree is the blocked voxel the segment enters first, by brute force", "[planner][map]") {
  const DenseMap map = randomMap(4, 0.05, 0.05);
  MapProbe probe(map);
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> pos(0.05, 2.85), posz(0.05, 1.35), len(0.0, 1.0);
  int blocked = 0, unknown_first = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vec3d a(pos(rng), pos(rng), posz(rng));
    const Vec3d b = a + (Vec3d(pos(rng), pos(rng), posz(rng)) - a) * len(rng);
    const std::optional<Coord> expected = test::bruteFirstNotFree(map, a, b);
    const std::optional<Coord> got = probe.firstNotFree(a, b);
    REQUIRE(got.has_value() == expected.has_value());
    REQUIRE(got.has_value() == !probe.isVisible(a, b));
    if (!got) continue;
    REQUIRE(*got == *expected);
    ++blocked;
    unknown_first += map.get(*got) == Occupancy::Unknown;
  }
  CHECK(blocked > 500);
  CHECK(unknown_first > 100);  // both kinds of blocking voxel occur
  CHECK(unknown_first < blocked - 100);
}

TEST_CASE("MapProbe::isSegmentClear is the exact capsule test", "[planner][map]") {
  const DenseMap map = randomMap(9);
  MapProbe probe(map);
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> pos(0.3, 2.6), posz(0.3, 1.1), len(0.0, 0.8);
  for (const double r : {0.12, 0.08, 0.03}) {
    int clear = 0;
    for (int i = 0; i < 3000; ++i) {
      const Vec3d a(pos(rng), pos(rng), posz(rng));
      const Vec3d b = a + (Vec3d(pos(rng), pos(rng), posz(rng)) - a).normalized() * len(rng);
      const bool ok = probe.isSegmentClear(a, b, r);
      // Every voxel centre within r of the segment is free (and, for radii thinner than a voxel,
      // every voxel the segment crosses); a hair of tolerance for rounding at the boundary.
      const bool thin = r < 0.0866;
      if (ok) REQUIRE(test::bruteSegmentClear(map, a, b, r * (1 - 1e-9)));
      if (ok && thin) REQUIRE(test::bruteVisible(map, a, b));
      if (test::bruteSegmentClear(map, a, b, r * (1 + 1e-9)) && (!thin || test::bruteVisible(map, a, b)) &&
          test::bruteClear(map, a, r) && test::bruteClear(map, b, r))
        REQUIRE(ok);
      clear += ok;
    }
    CHECK(clear > 20);
  }
}

namespace {
/// isSegmentClear's answer by brute force over every voxel near the segment, with the same
/// predicate in voxel units: the end points clear, the crossed voxels free (for capsules thinner
/// than half a voxel's diagonal; isVisible, itself checked against brute force above, decides
/// ties at voxel corners), and each voxel whose centre c has |a + t d - c|^2 <= r^2 (t the clamped
/// projection) free.
bool bruteCapsuleExact(const DenseMap& map, MapProbe& probe, const Vec3d& a_W, const Vec3d& b_W, double radius_m) {
  if (!probe.isClear(a_W, radius_m) || !probe.isClear(b_W, radius_m)) return false;
  const double s = map.voxelSize(), r = radius_m / s;
  if (r < 0.8660254037844386 && !probe.isVisible(a_W, b_W)) return false;
  const Vec3d a = a_W / s, b = b_W / s, d = b - a;
  const double len2 = d.squaredNorm();
  if (len2 < 1e-18) return true;
  const Coord lo = map.worldToVoxel(a_W.cwiseMin(b_W)).offsetBy(-int(r) - 2);
  const Coord hi = map.worldToVoxel(a_W.cwiseMax(b_W)).offsetBy(int(r) + 2);
  for (auto it = CoordBBox(lo, hi).begin(); it; ++it) {
    const Vec3d c((*it).x(), (*it).y(), (*it).z());
    const double t = std::clamp((c - a).dot(d) / len2, 0.0, 1.0);
    if ((a + d * t - c).squaredNorm() <= r * r && map.get(*it) != Occupancy::Free) return false;
  }
  return true;
}
}  // namespace

TEST_CASE("MapProbe::isSegmentClear gives the brute-force answer bit for bit, on every reader", "[planner][map]") {
  const DenseMap map = randomMap(31, 0.004, 0.002);  // sparse: capsules three voxels wide pass too
  const CachedMap cached(map);
  MapProbe plain(map), on_cache(cached), on_box(map);
  on_box.cacheBox(CoordBBox(Coord(4, 6, 1), Coord(22, 25, 12)));  // runs inside, across and outside it
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> pos(0.3, 2.6), posz(0.3, 1.1), len(0.0, 1.2);
  std::uniform_int_distribution<int> grid(3, 26), gridz(3, 11), axis(0, 2);
  // Whole and half voxels put voxel centres exactly on the capsule's surface.
  for (const double r : {0.3, 0.1, 0.05, 0.12, 0.07, 0.25}) {
    int clear = 0, blocked = 0;
    for (int i = 0; i < 2000; ++i) {
      Vec3d a, b;
      if (i % 2 == 0) {
        a = Vec3d(pos(rng), pos(rng), posz(rng));
        b = a + (Vec3d(pos(rng), pos(rng), posz(rng)) - a).normalized() * len(rng);
      } else {  // on voxel centres, along an axis or a diagonal
        a = Vec3d(grid(rng), grid(rng), gridz(rng)) * 0.1;
        Vec3d step = Vec3d::Zero();
        step[axis(rng)] = 0.1;
        if (i % 4 == 1) step[(axis(rng) + 1) % 3] += 0.1;
        b = a + step * double(1 + i % 7);
      }
      const bool want = bruteCapsuleExact(map, plain, a, b, r);
      REQUIRE(plain.isSegmentClear(a, b, r) == want);
      REQUIRE(on_cache.isSegmentClear(a, b, r) == want);
      REQUIRE(on_box.isSegmentClear(a, b, r) == want);
      if (plain.isClear(a, r) && plain.isClear(b, r)) REQUIRE(on_cache.isSegmentClearFromClearEnds(a, b, r) == want);
      (want ? clear : blocked) += 1;
    }
    CHECK(clear > 50);
    CHECK(blocked > 50);
  }
}

TEST_CASE("A MapProbe with a cached block answers as without", "[planner][map]") {
  const DenseMap map = randomMap(21);
  MapProbe plain(map), cached(map);
  cached.cacheBox(CoordBBox(Coord(5, 5, 2), Coord(20, 25, 12)));  // part of the map only
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> pos(0.0, 2.9), posz(0.0, 1.4);
  for (int i = 0; i < 2000; ++i) {
    const Vec3d a(pos(rng), pos(rng), posz(rng)), b(pos(rng), pos(rng), posz(rng));
    REQUIRE(plain.isVisible(a, b) == cached.isVisible(a, b));
    REQUIRE(plain.isClear(a, 0.15) == cached.isClear(a, 0.15));
    REQUIRE(plain.isSegmentClear(a, a + (b - a) * 0.1, 0.1) == cached.isSegmentClear(a, a + (b - a) * 0.1, 0.1));
  }
}

TEST_CASE("MapProbe rejects radii beyond 100 voxels", "[planner][map]") {
  const DenseMap map = randomMap(1);
  MapProbe probe(map);
  CHECK_THROWS_AS(probe.isClear(Vec3d(1, 1, 1), 10.5), std::invalid_argument);
  CHECK_THROWS_AS(probe.isClear(Vec3d(1, 1, 1), -0.1), std::invalid_argument);
}

TEST_CASE("AssumeFreeMap reads unknown voxels in its boxes as free and keeps occupied ones", "[planner][map]") {
  DenseMap map(0.1, CoordBBox(Coord(-10), Coord(10)));
  map.set(Coord(0), Occupancy::Occupied);
  map.set(Coord(5, 0, 0), Occupancy::Free);
  const AssumeFreeMap wrapped(map, {boxAround(Vec3d::Zero(), Vec3d::Constant(0.25))});
  auto reader = wrapped.reader();
  CHECK(reader->at(Coord(0)) == Occupancy::Occupied);
  CHECK(reader->at(Coord(1, 2, -2)) == Occupancy::Free);  // centre (0.1, 0.2, -0.2) is inside
  CHECK(reader->at(Coord(3, 0, 0)) == Occupancy::Unknown);  // centre 0.3 is outside
  CHECK(reader->at(Coord(5, 0, 0)) == Occupancy::Free);
  CHECK(wrapped.knownBounds() == CoordBBox(Coord(-2), Coord(5, 2, 2)));
  // The start problem it solves: in unknown space the vehicle can turn in place.
  MapProbe raw(map), assumed(wrapped);
  CHECK_FALSE(raw.isClear(Vec3d(0.0, 0.0, 0.15), 0.05));
  CHECK(assumed.isClear(Vec3d(0.0, 0.0, 0.15), 0.05));
}

TEST_CASE("TsdfMapQuery without thin and hit obstacles agrees with TsdfVolume::state on every voxel",
          "[planner][map]") {
  TsdfConfig config;
  config.voxel_size_m = 0.1;
  TsdfVolume volume(config);
  // A wall 2 m ahead of the camera (z forward), 2 x 1.5 m, seen from two poses.
  PointCloud wall_S;
  for (double u = -1.0; u <= 1.0; u += 0.02)
    for (double v = -0.75; v <= 0.75; v += 0.02) wall_S.emplace_back(float(u), float(v), 2.0f);
  volume.integrate(1, wall_S, Pose3d::Identity());
  Pose3d T = Pose3d::Identity();
  T.translation() = Vec3d(0.3, 0.1, -0.2);
  volume.integrate(2, wall_S, T);

  TsdfMapQueryConfig exact;
  exact.thin_obstacles = false;
  exact.hit_obstacles = false;
  const TsdfMapQuery query(volume, exact);
  CHECK(query.voxelSize() == 0.1);
  CHECK(query.knownBounds() == volume.activeBoundingBox());
  auto reader = query.reader();
  std::size_t counts[3] = {0, 0, 0};
  for (auto it = query.knownBounds().expandBy(1).begin(); it; ++it) {
    const VoxelState expected = volume.state(*it);
    const Occupancy got = reader->at(*it);
    const Occupancy want = expected == VoxelState::Free       ? Occupancy::Free
                           : expected == VoxelState::Occupied ? Occupancy::Occupied
                                                              : Occupancy::Unknown;
    REQUIRE(got == want);
    ++counts[int(got)];
  }
  // readBox (leaf by leaf) reads the same states, also through the assume-free wrapper.
  const AssumeFreeMap wrapped(query, {boxAround(Vec3d(0, 0, 0.5), Vec3d(0.3, 0.3, 0.3))});
  auto wrapped_reader = wrapped.reader();
  for (const CoordBBox& box : {query.knownBounds().expandBy(3), CoordBBox(Coord(-5, -3, 2), Coord(4, 9, 30))}) {
    std::vector<Occupancy> block(box.volume()), wrapped_block(box.volume());
    reader->readBox(box, block.data());
    wrapped_reader->readBox(box, wrapped_block.data());
    std::size_t i = 0;
    for (int x = box.min().x(); x <= box.max().x(); ++x)
      for (int y = box.min().y(); y <= box.max().y(); ++y)
        for (int z = box.min().z(); z <= box.max().z(); ++z, ++i) {
          REQUIRE(block[i] == reader->at(Coord(x, y, z)));
          REQUIRE(wrapped_block[i] == wrapped_reader->at(Coord(x, y, z)));
        }
  }
  CHECK(counts[int(Occupancy::Free)] > 1000);
  CHECK(counts[int(Occupancy::Occupied)] > 100);
  CHECK(counts[int(Occupancy::Unknown)] > 100);
}

namespace {
/// Depth images of a 4 cm square post (axis at post_xy, z in [-1.5, 1.5] m) inside a 6 x 6 x 3 m
/// room centred on the origin, from 12 cameras on a 2 m circle around it looking at its axis,
/// integrated at 0.1 m: every voxel around the post is also crossed by rays that pass beside it.
/// Without the post (post = false) only the room is seen.
TsdfVolume postScene(bool post, const Eigen::Vector2d& post_xy) {
  TsdfConfig config;
  config.voxel_size_m = 0.1;
  TsdfVolume volume(config);
  CameraIntrinsics K;
  K.width = 320, K.height = 240, K.fx = K.fy = 193.6, K.cx = 160.0, K.cy = 120.0;
  const Vec3d lo(post_xy.x() - 0.02, post_xy.y() - 0.02, -1.5), hi(post_xy.x() + 0.02, post_xy.y() + 0.02, 1.5);
  const Vec3d room(3.0, 3.0, 1.5);  // half sizes
  for (int k = 0; k < 12; ++k) {
    const double th = 2.0 * M_PI * k / 12.0;
    const Vec3d o(post_xy.x() + 2.0 * std::cos(th), post_xy.y() + 2.0 * std::sin(th), 0.0);
    const Vec3d forward(-std::cos(th), -std::sin(th), 0.0), down(0, 0, -1);
    Pose3d T = Pose3d::Identity();
    T.linear().col(0) = down.cross(forward);  // camera x: right
    T.linear().col(1) = down;
    T.linear().col(2) = forward;
    T.translation() = o;
    DepthImage depth(K.width, K.height);
    for (int v = 0; v < K.height; ++v)
      for (int u = 0; u < K.width; ++u) {
        const Vec3d d = T.linear() * Vec3d((u + 0.5 - K.cx) / K.fx, (v + 0.5 - K.cy) / K.fy, 1.0);  // depth 1 per unit
        double t = std::numeric_limits<double>::infinity();  // the room's walls, floor and ceiling
        for (int a = 0; a < 3; ++a)
          if (std::abs(d[a]) > 1e-12) t = std::min(t, ((d[a] > 0 ? room[a] : -room[a]) - o[a]) / d[a]);
        if (post) {  // slab test against the post's box
          double t0 = 0.0, t1 = t;
          for (int a = 0; a < 3; ++a) {
            if (std::abs(d[a]) < 1e-12) {
              if (o[a] < lo[a] || o[a] > hi[a]) t0 = t1 + 1.0;
              continue;
            }
            double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
            if (ta > tb) std::swap(ta, tb);
            t0 = std::max(t0, ta), t1 = std::min(t1, tb);
          }
          if (t0 <= t1) t = t0;
        }
        depth.at(u, v) = float(t);
      }
    volume.integrate(FrameId(k + 1), depth, K, T);
  }
  return volume;
}

/// Whether a reader sees an occupied voxel among the 3 x 3 voxels around (x, y) at height z.
bool occupiedNear(MapReader& reader, const MapQuery& map, const Vec3d& p) {
  const Coord c = map.worldToVoxel(p);
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
      if (reader.at(c.offsetBy(dx, dy, 0)) == Occupancy::Occupied) return true;
  return false;
}
}  // namespace

TEST_CASE("TsdfMapQuery reads a post thinner than a voxel as an obstacle, and walls stay as the map has them",
          "[planner][map]") {
  const Eigen::Vector2d post_xy(0.03, 0.03);  // off the voxel centres
  // Four readers: the map's own states, tsdf valleys only, hits only, and both (the default).
  TsdfMapQueryConfig exact_params, valley_params, hits_params;
  exact_params.thin_obstacles = exact_params.hit_obstacles = false;
  valley_params.hit_obstacles = false;
  hits_params.thin_obstacles = false;
  {
    const TsdfVolume volume = postScene(true, post_xy);
    const TsdfMapQuery both(volume), exact(volume, exact_params), valleys(volume, valley_params),
        hits(volume, hits_params);
    auto both_reader = both.reader();
    auto exact_reader = exact.reader();
    auto valley_reader = valleys.reader();
    auto hits_reader = hits.reader();
    int exact_misses = 0;
    for (double z = -0.4; z <= 0.4 + 1e-9; z += 0.1) {
      INFO("z = " << z);
      const Vec3d p(post_xy.x(), post_xy.y(), z);
      CHECK(occupiedNear(*both_reader, both, p));
      CHECK(occupiedNear(*valley_reader, valleys, p));
      CHECK(occupiedNear(*hits_reader, hits, p));  // each rule finds the post on its own
      exact_misses += occupiedNear(*exact_reader, exact, p) ? 0 : 1;
    }
    // The reason for the rules: the map's own states lose the post at most heights.
    CHECK(exact_misses >= 5);
    // readBox reads what at() reads, valleys and hits included.
    const CoordBBox box(Coord(-8, -8, -5), Coord(8, 8, 5));
    for (MapReader* reader : {both_reader.get(), valley_reader.get(), hits_reader.get()}) {
      std::vector<Occupancy> block(box.volume());
      reader->readBox(box, block.data());
      std::size_t i = 0, added = 0;
      for (auto it = box.begin(); it; ++it, ++i) {
        REQUIRE(block[i] == reader->at(*it));
        added += block[i] != exact_reader->at(*it);
      }
      CHECK(added > 0);
    }
  }
  {
    // Only the room: no voxel reads differently, so walls are not thickened.
    const TsdfVolume volume = postScene(false, post_xy);
    const TsdfMapQuery both(volume), exact(volume, exact_params);
    auto both_reader = both.reader();
    auto exact_reader = exact.reader();
    std::size_t occupied = 0, with_hits = 0;
    for (auto it = volume.activeBoundingBox().begin(); it; ++it) {
      REQUIRE(both_reader->at(*it) == exact_reader->at(*it));
      occupied += exact_reader->at(*it) == Occupancy::Occupied;
      with_hits += exact_reader->at(*it) == Occupancy::Free && volume.sample(*it).hits >= 2;
    }
    CHECK(occupied > 100);
    CHECK(with_hits > 20);  // free voxels in front of the walls hold their end points (55 here)
  }
  TsdfMapQueryConfig bad;
  bad.thin_margin_vox = 0.0;
  CHECK_THROWS_WITH(bad.validate(), Catch::Contains("thin_margin_vox"));
  TsdfMapQueryConfig no_hits;
  no_hits.min_hits = 0;
  CHECK_THROWS_WITH(no_hits.validate(), Catch::Contains("min_hits"));
}

TEST_CASE("TsdfMapQuery reads a post as an obstacle from its hits when rays beside it leave no valley",
          "[planner][map]") {
  // A hand-made map: a 3 x 3 bundle of parallel rays along +x (y, z in -0.1, 0, 0.1 m) to a wall at
  // x = 1.0 m, 20 rays each, so the voxels along x = 0.1-0.9 m read free with a flat tsdf (no
  // valley). Then a few end points in the middle, as a side-seen 2.5 cm upright leaves them.
  TsdfConfig config;
  config.voxel_size_m = 0.1;
  TsdfVolume volume(config);
  const PointCloud wall_S(20, Vec3f(1.0f, 0.0f, 0.0f));
  FrameId id = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dz = -1; dz <= 1; ++dz)
      volume.integrate(id++, wall_S, Pose3d(Eigen::Translation3d(0.0, 0.1 * dy, 0.1 * dz)));
  // Three end points in voxel (5, 0, 0), centre 0.5 m; three in (5, 1, 0), at the bundle's edge.
  volume.integrate(id++, PointCloud(3, Vec3f(0.52f, 0.01f, 0.0f)), Pose3d::Identity());
  volume.integrate(id++, PointCloud(3, Vec3f(0.52f, 0.0f, 0.0f)), Pose3d(Eigen::Translation3d(0.0, 0.1, 0.0)));
  const Coord post(5, 0, 0), edge(5, 1, 0);
  REQUIRE(volume.sample(post).hits == 3);
  REQUIRE(volume.sample(edge).hits == 3);
  REQUIRE(volume.state(post) == VoxelState::Free);  // the rays through it to the wall carve it
  REQUIRE(volume.state(edge) == VoxelState::Free);
  REQUIRE(volume.state(Coord(5, 2, 0)) == VoxelState::Unknown);

  TsdfMapQueryConfig valley_only;
  valley_only.hit_obstacles = false;
  CHECK(TsdfMapQuery(volume, valley_only).reader()->at(post) == Occupancy::Free);
  CHECK(TsdfMapQuery(volume).reader()->at(post) == Occupancy::Occupied);
  TsdfMapQueryConfig strict;
  strict.min_hits = 4;  // more hits needed than the voxel holds
  CHECK(TsdfMapQuery(volume, strict).reader()->at(post) == Occupancy::Free);
  // Beside unknown space the hits are a surface being discovered: the voxel stays free (a frontier).
  CHECK(TsdfMapQuery(volume).reader()->at(edge) == Occupancy::Free);
  // The wall's end points sit in its occupied voxel: nothing changes there or in front of it.
  const Coord wall(10, 0, 0), front(9, 0, 0);
  CHECK(volume.sample(wall).hits == 20);
  CHECK(TsdfMapQuery(volume).reader()->at(wall) == Occupancy::Occupied);
  CHECK(TsdfMapQuery(volume).reader()->at(front) == TsdfMapQuery(volume, valley_only).reader()->at(front));

  // Lines of sight read the map's own states: the post keeps the vehicle away but hides only a
  // sliver of its voxel from a camera. The start box wrapper keeps that, and adds its box to both.
  const TsdfMapQuery map(volume);
  REQUIRE(&map.sightMap() != &map);
  CHECK(map.sightMap().reader()->at(post) == Occupancy::Free);
  const Vec3d eye_W(0.1, 0.0, 0.0), beyond_W(0.9, 0.0, 0.0);
  MapProbe flight(map), sight(map.sightMap());
  CHECK_FALSE(flight.isVisible(eye_W, beyond_W));
  CHECK(sight.isVisible(eye_W, beyond_W));
  const Coord unknown(5, 2, 0);
  const AssumeFreeMap start(map, {boxAround(map.voxelCenter(unknown), Vec3d::Constant(0.01))});
  CHECK(start.reader()->at(post) == Occupancy::Occupied);
  CHECK(start.sightMap().reader()->at(post) == Occupancy::Free);
  CHECK(start.reader()->at(unknown) == Occupancy::Free);
  CHECK(start.sightMap().reader()->at(unknown) == Occupancy::Free);
  // Without the rules, and for other maps, sight reads the same map.
  TsdfMapQueryConfig own;
  own.thin_obstacles = own.hit_obstacles = false;
  const TsdfMapQuery exact(volume, own);
  CHECK(&exact.sightMap() == &exact);
  const AssumeFreeMap exact_start(exact, {});
  CHECK(&exact_start.sightMap() == &exact_start);
}

TEST_CASE("CachedMap reads every voxel as its base, inside and outside the cached blocks", "[planner][map]") {
  // A base whose bounds start at negative, unaligned coordinates: blocks straddle its edges.
  DenseMap base(0.1, CoordBBox(Coord(-13, -7, -3), Coord(18, 11, 9)));
  base.fill(base.extent(), Occupancy::Free);
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> state(0, 9);
  for (auto it = base.extent().begin(); it; ++it)
    if (const int s = state(rng); s < 2) base.set(*it, s == 0 ? Occupancy::Occupied : Occupancy::Unknown);
  const CachedMap cached(base);
  CHECK(cached.blocksRead() == 0);  // nothing is read before the first query
  CHECK(cached.knownBounds() == base.knownBounds());
  CHECK(cached.voxelSize() == base.voxelSize());
  auto want = base.reader();
  auto got = cached.reader();
  const CoordBBox around = base.extent().expandBy(9);  // the table's blocks and beyond
  for (int pass = 0; pass < 2; ++pass)                 // the second pass answers from the blocks the first read
    for (auto it = around.begin(); it; ++it) REQUIRE(got->at(*it) == want->at(*it));
  // Blocks of 8^3 covering [-13, 18] x [-7, 11] x [-3, 9]: 5 x 3 x 3 of them, each read once.
  CHECK(cached.blocksRead() == 45);
  test::requireReadBoxMatchesAt(*got, CoordBBox(Coord(-15, -9, -5), Coord(3, 4, 2)));  // beyond the table

  // Boxes inside the table are assembled from blocks, filled by readBox itself when missing.
  const CachedMap fresh(base);
  auto boxes = fresh.reader();
  for (const CoordBBox& box :
       {CoordBBox(Coord(-12, -6, -2), Coord(17, 10, 8)), CoordBBox(Coord(3, -1, -3), Coord(3, -1, 9)),
        CoordBBox(Coord(-9, 2, 4), Coord(14, 2, 4)), CoordBBox(Coord(1, 1, 1), Coord(6, 3, 5)),
        CoordBBox(Coord(0), Coord(0))}) {
    std::vector<Occupancy> got_box(box.volume()), want_box(box.volume());
    boxes->readBox(box, got_box.data());
    want->readBox(box, want_box.data());
    REQUIRE(got_box == want_box);
  }
  CHECK(fresh.blocksRead() == 45);

  // Boxes whose missing blocks are most of the blocks spanning them are read from the base in one
  // piece, others block by block; either way the states are the base's, and each block is kept once.
  const CachedMap partly(base);
  auto mixed = partly.reader();
  for (const Coord& c : {Coord(-12, -6, -2), Coord(5, 5, 5), Coord(17, 10, 8)}) REQUIRE(mixed->at(c) == want->at(c));
  CHECK(partly.blocksRead() == 3);
  for (const CoordBBox& box :
       {CoordBBox(Coord(-12, -6, -2), Coord(2, 10, 8)), CoordBBox(Coord(-12, -6, -2), Coord(17, 10, 8))}) {
    std::vector<Occupancy> got_box(box.volume()), want_box(box.volume());
    mixed->readBox(box, got_box.data());
    want->readBox(box, want_box.data());
    REQUIRE(got_box == want_box);
  }
  CHECK(partly.blocksRead() == 45);
}

TEST_CASE("CachedMap reads boxes of a TSDF map, with its neighbour rules, as the map reads them", "[planner][map]") {
  const TsdfVolume volume = postScene(true, Eigen::Vector2d(0.03, 0.03));
  const TsdfMapQuery tsdf(volume);
  const CachedMap cached(tsdf);
  auto want = tsdf.reader();
  auto got = cached.reader();
  // A box over many blocks (one read), then boxes that overlap it and blocks beyond it.
  for (const CoordBBox& box :
       {CoordBBox(Coord(-20, -20, -6), Coord(20, 20, 10)), CoordBBox(Coord(-33, -5, -9), Coord(40, 3, 12)),
        CoordBBox(Coord(-3, -3, -3), Coord(3, 3, 3))}) {
    std::vector<Occupancy> got_box(box.volume()), want_box(box.volume());
    got->readBox(box, got_box.data());
    want->readBox(box, want_box.data());
    REQUIRE(got_box == want_box);
  }
  for (auto it = CoordBBox(Coord(-34, -22, -9), Coord(41, 21, 12)).begin(); it; ++it)
    REQUIRE(got->at(*it) == want->at(*it));
}

TEST_CASE("CachedMap readers on many threads agree with the base and read each block once", "[planner][map]") {
  const DenseMap base = randomMap(17);
  const CachedMap cached(base);
  const CoordBBox around = base.extent().expandBy(3);
  std::vector<Coord> queries;
  std::mt19937 rng(9);
  std::uniform_int_distribution<int> x(around.min().x(), around.max().x()), z(around.min().z(), around.max().z());
  for (int i = 0; i < 200000; ++i) queries.emplace_back(x(rng), x(rng), z(rng));
  std::atomic<int> mismatches{0};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queries.size(), 256),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      auto want = base.reader();
                      auto got = cached.reader();
                      for (std::size_t i = r.begin(); i < r.end(); ++i)
                        if (got->at(queries[i]) != want->at(queries[i])) ++mismatches;
                    });
  CHECK(mismatches == 0);
  CHECK(cached.blocksRead() == 4 * 4 * 2);  // [0, 29] x [0, 29] x [0, 14]: every block was asked for
}

TEST_CASE("CachedMap keeps no blocks beyond its limit, and caches a separate sight map", "[planner][map]") {
  const DenseMap base = randomMap(3);
  const CachedMap uncached(base, /*max_blocks=*/31);  // the map spans 32 blocks
  auto want = base.reader();
  auto got = uncached.reader();
  for (auto it = base.extent().begin(); it; ++it) REQUIRE(got->at(*it) == want->at(*it));
  CHECK(uncached.blocksRead() == 0);
  CHECK(&uncached.sightMap() == &uncached);

  // The TSDF map with thin-obstacle rules has its own sight map (without them): so has the cache.
  const TsdfVolume volume = postScene(true, Eigen::Vector2d(0.03, 0.03));
  const TsdfMapQuery tsdf(volume);
  REQUIRE(&tsdf.sightMap() != &tsdf);
  const CachedMap cached(tsdf);
  REQUIRE(&cached.sightMap() != &cached);
  auto flight = cached.reader(), flight_base = tsdf.reader();
  auto sight = cached.sightMap().reader(), sight_base = tsdf.sightMap().reader();
  int differ = 0;
  for (auto it = CoordBBox(Coord(-8, -8, -5), Coord(8, 8, 5)).begin(); it; ++it) {
    REQUIRE(flight->at(*it) == flight_base->at(*it));
    REQUIRE(sight->at(*it) == sight_base->at(*it));
    differ += flight->at(*it) != sight->at(*it) ? 1 : 0;
  }
  CHECK(differ > 0);  // the two maps differ at the post, and each cache follows its own
}
