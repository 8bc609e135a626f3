// Viewpoints: every viewpoint returned is clear and sees its cluster (recounted by brute force),
// yaw points at the cluster, and occlusion by occupied and unknown voxels.
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/frontier.hpp"
#include "vdbmap/planner/vehicle_state.hpp"
#include "vdbmap/planner/viewpoint.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>

using namespace vdbmap;
using namespace vdbmap::planner;
using openvdb::Coord;
using openvdb::CoordBBox;

namespace {
/// The cluster samples a camera at the viewpoint sees (FUEL's rule, look_into_unknown off),
/// recounted with the brute-force ray test.
int bruteSeen(const DenseMap& map, const FrontierCluster& cluster, const CameraFrustum& camera, const Viewpoint& v) {
  int seen = 0;
  for (const Coord& s : cluster.samples) {
    const Vec3d p = map.voxelCenter(s);
    seen += camera.contains(v.position_W, v.yaw_rad, p) && test::bruteVisible(map, p, v.position_W);
  }
  return seen;
}

/// The cluster samples a camera at the viewpoint observes (look_into_unknown, the default),
/// recounted by brute force: an unknown face neighbour inside the frustum whose ray from the eye
/// first leaves free space within unknown_entry_reach_vox of it, into unknown space.
int bruteObserved(const DenseMap& map, const std::vector<Coord>& samples, const ViewpointConfig& params,
                  const Vec3d& eye, double yaw) {
  int seen = 0;
  for (const Coord& s : samples) {
    bool observed = false;
    for (const Coord& d : kFaceNeighbours) {
      const Coord n = s + d;
      const Vec3d p = map.voxelCenter(n);
      if (map.get(n) != Occupancy::Unknown || !params.camera.contains(eye, yaw, p)) continue;
      if (params.frontier_bounds_W && !params.frontier_bounds_W->contains(p)) continue;
      const std::optional<Coord> entry = test::bruteFirstNotFree(map, eye, p);
      REQUIRE(entry);  // n itself is not free
      const Coord off = *entry - n;
      observed |= map.get(*entry) == Occupancy::Unknown &&
                  std::max({std::abs(off.x()), std::abs(off.y()), std::abs(off.z())}) <= params.unknown_entry_reach_vox;
    }
    seen += observed;
  }
  return seen;
}
int bruteObserved(const DenseMap& map, const FrontierCluster& cluster, const ViewpointConfig& params,
                  const Viewpoint& v) {
  return bruteObserved(map, cluster.samples, params, v.position_W, v.yaw_rad);
}

/// The samples observed by FUEL's rule with vertical_into_unknown, recounted by brute force: a
/// sample with an unknown neighbour beside it counts when seen, one whose unknown neighbours lie
/// only above or below it when observed as bruteObserved counts.
int bruteObservedVertical(const DenseMap& map, const std::vector<Coord>& samples, const ViewpointConfig& params,
                          const Vec3d& eye, double yaw) {
  int seen = 0;
  for (const Coord& s : samples) {
    bool beside = false;
    for (const Coord& d : kFaceNeighbours) beside |= d.z() == 0 && map.get(s + d) == Occupancy::Unknown;
    if (beside) {
      const Vec3d p = map.voxelCenter(s);
      seen += params.camera.contains(eye, yaw, p) && test::bruteVisible(map, p, eye);
    } else {
      seen += bruteObserved(map, {s}, params, eye, yaw);
    }
  }
  return seen;
}

/// The defaults with look_into_unknown on.
ViewpointConfig intoUnknown() {
  ViewpointConfig p;
  p.look_into_unknown = true;
  return p;
}
}  // namespace

TEST_CASE("CameraFrustum::contains follows the pinhole frustum, range and yaw", "[planner][viewpoint]") {
  const CameraFrustum cam;  // tan x 0.826, tan y 0.620, 4.5 m
  const Vec3d eye(0, 0, 0);
  CHECK(cam.contains(eye, 0.0, Vec3d(2, 0, 0)));
  CHECK(cam.contains(eye, 0.0, Vec3d(2, 1.6, 0)));
  CHECK_FALSE(cam.contains(eye, 0.0, Vec3d(2, 1.7, 0)));
  CHECK(cam.contains(eye, 0.0, Vec3d(2, 0, 1.2)));
  CHECK_FALSE(cam.contains(eye, 0.0, Vec3d(2, 0, 1.3)));
  CHECK_FALSE(cam.contains(eye, 0.0, Vec3d(-1, 0, 0)));
  CHECK_FALSE(cam.contains(eye, 0.0, Vec3d(4.6, 0, 0)));
  CHECK(cam.contains(eye, M_PI / 2, Vec3d(0, 2, 0)));
  CHECK_FALSE(cam.contains(eye, M_PI / 2, Vec3d(2, 0, 0)));
}

TEST_CASE("The nearest point of a vertical line that a level camera turns to see", "[planner][viewpoint]") {
  const CameraFrustum cam;  // tan y 0.620: 1.24 m up or down at 2 m across
  const Vec3d eye(1, 1, 1);
  const double tan_y = cam.tan_half_fov_y;
  // Within the vertical half field of view, at any bearing: the point itself.
  CHECK(*cam.nearestInViewOnVertical(eye, Vec3d(3, 1, 2.2), 0.25) == Vec3d(3, 1, 2.2));
  CHECK(*cam.nearestInViewOnVertical(eye, Vec3d(1, -1, 0), 0.25) == Vec3d(1, -1, 0));
  // Above or below it: the steepest point of its vertical line in view.
  const std::optional<Vec3d> above = cam.nearestInViewOnVertical(eye, Vec3d(1.6, 1.8, 3.0), 0.25);
  REQUIRE(above);
  CHECK(above->head<2>() == Eigen::Vector2d(1.6, 1.8));
  CHECK(above->z() == Approx(1.0 + 1.0 * tan_y).epsilon(1e-12));  // 1 m across
  const std::optional<Vec3d> below = cam.nearestInViewOnVertical(eye, Vec3d(1.0, 0.5, -1.0), 0.25);
  REQUIRE(below);
  CHECK(below->z() == Approx(1.0 - 0.5 * tan_y).epsilon(1e-12));
  // Less than min_across_m across (or straight above): none.
  CHECK_FALSE(cam.nearestInViewOnVertical(eye, Vec3d(1.2, 1, 2.0), 0.25));
  CHECK_FALSE(cam.nearestInViewOnVertical(eye, Vec3d(1, 1, 2.0), 0.0));
  CHECK(cam.nearestInViewOnVertical(eye, Vec3d(1.2, 1, 2.0), 0.1));
}

TEST_CASE("The nearest point of a vertical line in view of a camera that faces it only within a tolerance",
          "[planner][viewpoint]") {
  // Turned a radians off the line, a level camera sees it at cos(a) of its horizontal distance in
  // depth, so less of it: the point at the edge of the view of a camera facing the line exactly
  // is out of view 0.2 rad off. With the tolerance, the point returned is in view of every yaw
  // within it (range aside), and a point inside that band is returned as it is.
  const CameraFrustum cam;
  const Vec3d eye(1, 1, 1), steep(2.5, 2.0, 3.0);  // 1.80 m across, 2 m up
  const double bearing = std::atan2(steep.y() - eye.y(), steep.x() - eye.x());
  const std::optional<Vec3d> exact = cam.nearestInViewOnVertical(eye, steep, 0.25);
  REQUIRE(exact);
  CHECK_FALSE(cam.contains(eye, bearing + 0.2, *exact - Vec3d(0, 0, 1e-9)));
  for (const double tolerance : {0.2, 0.5, 0.69}) {
    INFO("tolerance " << tolerance << " rad");
    const std::optional<Vec3d> p = cam.nearestInViewOnVertical(eye, steep, 0.25, tolerance);
    REQUIRE(p);
    CHECK(p->head<2>() == steep.head<2>());
    CHECK(p->z() < exact->z());
    for (const double off : {-1.0, -0.5, 0.0, 0.5, 1.0})
      CHECK(cam.contains(eye, bearing + off * tolerance * (1.0 - 1e-9), *p - Vec3d(0, 0, 1e-9)));
    const Vec3d inside(2.5, 2.0, 1.5);  // 0.28 rad up: in view of every yaw within any of these
    CHECK(*cam.nearestInViewOnVertical(eye, inside, 0.25, tolerance) == inside);
  }
  CHECK_THROWS_AS(cam.nearestInViewOnVertical(eye, steep, 0.25, -0.1), std::invalid_argument);
  CHECK_THROWS_AS(cam.nearestInViewOnVertical(eye, steep, 0.25, 0.8), std::invalid_argument);  // beyond 0.69 rad
}

TEST_CASE("Occupied and unknown voxels occlude; free space does not", "[planner][viewpoint]") {
  DenseMap map(0.1, CoordBBox(Coord(-5), Coord(40, 5, 5)));
  map.fill(map.extent(), Occupancy::Free);
  MapProbe probe(map);
  const std::vector<Coord> target{Coord(30, 0, 0)};
  const CameraFrustum cam;
  CHECK(countVisible(probe, Vec3d(0.5, 0, 0), 0.0, target, cam) == 1);
  CHECK(countVisible(probe, Vec3d(0.5, 0, 0), M_PI, target, cam) == 0);  // looking away
  map.set(Coord(20, 0, 0), Occupancy::Occupied);
  CHECK(countVisible(probe, Vec3d(0.5, 0, 0), 0.0, target, cam) == 0);
  map.set(Coord(20, 0, 0), Occupancy::Unknown);
  CHECK(countVisible(probe, Vec3d(0.5, 0, 0), 0.0, target, cam) == 0);
  map.set(Coord(20, 0, 0), Occupancy::Free);
  CHECK(countVisible(probe, Vec3d(0.5, 0, 0), 0.0, target, cam) == 1);
}

TEST_CASE("Every viewpoint is clear, sees its cluster, and looks at it", "[planner][viewpoint]") {
  const DenseMap map = test::halfKnownRoom();
  FrontierMap frontiers;  // FUEL defaults: min 100 voxels, split beyond 2 m
  frontiers.rebuild(map);
  REQUIRE(frontiers.clusters().size() == 2);  // the 5.8 m wide plane is split in halves of 2.9 m

  const ViewpointConfig params;
  const double radii[] = {1.5, 1.5 + 1.0 / 3.0, 1.5 + 2.0 / 3.0, 2.5};
  std::size_t total = 0;
  for (const FrontierCluster& cluster : frontiers.clusters()) {
    const std::vector<Viewpoint> views = computeViewpoints(cluster, map, params);
    total += views.size();
    for (std::size_t i = 0; i < views.size(); ++i) {
      const Viewpoint& v = views[i];
      // Clear: every voxel centre within the clearance is free (brute force).
      REQUIRE(test::bruteClear(map, v.position_W, params.min_clearance_m));
      // Sees its cluster: recount with the brute-force ray test.
      const int seen = bruteSeen(map, cluster, params.camera, v);
      REQUIRE(seen == v.visible_samples);
      REQUIRE(seen > params.min_visible_samples);
      // On a ring around the centroid, at its height.
      const double r = (v.position_W - cluster.centroid_W).head<2>().norm();
      REQUIRE(std::any_of(std::begin(radii), std::end(radii), [&](double x) { return std::abs(x - r) < 1e-9; }));
      REQUIRE(v.position_W.z() == Approx(cluster.centroid_W.z()));
      // Looks at the cluster: the centroid is inside the horizontal field of view.
      const Vec3d to = cluster.centroid_W - v.position_W;
      REQUIRE(yawDistance(v.yaw_rad, std::atan2(to.y(), to.x())) < std::atan(params.camera.tan_half_fov_x));
      // Best first.
      if (i > 0) REQUIRE(views[i - 1].visible_samples >= v.visible_samples);
    }
  }
  CHECK(total > 20);
  // The parallel overload gives the same viewpoints.
  std::vector<const FrontierCluster*> all;
  for (const FrontierCluster& c : frontiers.clusters()) all.push_back(&c);
  const auto parallel = computeViewpoints(all, map, params);
  REQUIRE(parallel.size() == all.size());
  for (std::size_t i = 0; i < all.size(); ++i) {
    const auto single = computeViewpoints(*all[i], map, params);
    REQUIRE(parallel[i].size() == single.size());
    for (std::size_t k = 0; k < single.size(); ++k) {
      CHECK(parallel[i][k].position_W == single[k].position_W);
      CHECK(parallel[i][k].visible_samples == single[k].visible_samples);
    }
  }
}

TEST_CASE("Looking into the unknown, every viewpoint observes its cluster as the brute-force rule counts",
          "[planner][viewpoint]") {
  const DenseMap map = test::halfKnownRoom();
  FrontierMap frontiers;
  frontiers.rebuild(map);
  const ViewpointConfig params = intoUnknown();
  std::size_t total = 0;
  for (const FrontierCluster& cluster : frontiers.clusters())
    for (const Viewpoint& v : computeViewpoints(cluster, map, params)) {
      REQUIRE(test::bruteClear(map, v.position_W, params.min_clearance_m));
      REQUIRE(v.looks_into_unknown);
      REQUIRE(bruteObserved(map, cluster, params, v) == v.visible_samples);
      REQUIRE(v.visible_samples > params.min_visible_samples);
      ++total;
    }
  CHECK(total > 20);
  // FUEL's rule, the default, marks its viewpoints so.
  for (const Viewpoint& v : computeViewpoints(frontiers.clusters()[0], map, ViewpointConfig{}))
    REQUIRE_FALSE(v.looks_into_unknown);
}

TEST_CASE("observedSamples equals the brute-force rule for every entry reach, in and out of the frontier box",
          "[planner][viewpoint]") {
  // The half-known room with clutter: occupied and unknown voxels scattered in its known half.
  DenseMap map = test::halfKnownRoom();
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (auto it = CoordBBox(Coord(1), Coord(38, 58, 28)).begin(); it; ++it) {
    const double x = u(rng);
    if (x < 0.01)
      map.set(*it, Occupancy::Occupied);
    else if (x < 0.02)
      map.set(*it, Occupancy::Unknown);
  }
  std::vector<Coord> samples;  // every free voxel beside unknown space
  const std::unique_ptr<MapReader> reader = map.reader();
  for (auto it = CoordBBox(Coord(1), Coord(39, 58, 28)).begin(); it; ++it)
    if (isFrontierVoxel(*reader, *it)) samples.push_back(*it);
  REQUIRE(samples.size() > 1000);
  std::uniform_real_distribution<double> px(0.3, 3.6), py(0.3, 5.6), pz(0.3, 2.6), yaw(-M_PI, M_PI);
  MapProbe probe(map);
  std::size_t observed_total = 0, visible_total = 0, vertical_total = 0, vertical_fewer = 0;
  for (int i = 0; i < 40; ++i) {
    ViewpointConfig params = intoUnknown();
    params.unknown_entry_reach_vox = i % 3;
    if (i % 4 == 3) params.frontier_bounds_W = Eigen::AlignedBox3d(Vec3d(0, 0, 0), Vec3d(3.8, 6, 3));
    const Vec3d eye(px(rng), py(rng), pz(rng));
    const double y = yaw(rng);
    const std::vector<Coord> got = observedSamples(probe, eye, y, samples, params);
    REQUIRE(int(got.size()) == bruteObserved(map, samples, params, eye, y));
    REQUIRE(countObserved(probe, eye, y, samples, params) == int(got.size()));
    REQUIRE(observesAny(probe, eye, y, samples, params) == !got.empty());
    REQUIRE(std::is_sorted(got.begin(), got.end(), [&](const Coord& a, const Coord& b) {
      return std::find(samples.begin(), samples.end(), a) < std::find(samples.begin(), samples.end(), b);
    }));
    observed_total += got.size();
    params.look_into_unknown = false;
    const std::vector<Coord> fuel = observedSamples(probe, eye, y, samples, params);
    REQUIRE(fuel == visibleVoxels(probe, eye, y, samples, params.camera));
    REQUIRE(observesAny(probe, eye, y, samples, params) == !fuel.empty());
    REQUIRE(observesAny(probe, eye, y, {}, params) == false);
    visible_total += fuel.size();
    params.vertical_into_unknown = true;
    const std::vector<Coord> vertical = observedSamples(probe, eye, y, samples, params);
    REQUIRE(int(vertical.size()) == bruteObservedVertical(map, samples, params, eye, y));
    REQUIRE(countObserved(probe, eye, y, samples, params) == int(vertical.size()));
    REQUIRE(observesAny(probe, eye, y, samples, params) == !vertical.empty());
    vertical_total += vertical.size();
    vertical_fewer += vertical.size() < fuel.size();
  }
  CHECK(observed_total > 500);
  CHECK(visible_total > 500);
  CHECK(vertical_total > 500);
  CHECK(vertical_fewer > 0);  // the room's floor and ceiling frontier is seen but not looked into
}

TEST_CASE("A free layer under unknown space seen edge-on is visible but not observed", "[planner][viewpoint]") {
  // A known-free room 4 m wide whose voxels from z = 1.7 m up are unknown over x >= 1 m, as the top
  // of a shelf board the camera has only seen from below: the free voxels at z = 1.6 m under it
  // are frontier with the unknown above them.
  DenseMap map(0.1, CoordBBox(Coord(-2), Coord(42, 22, 32)));
  map.fill(CoordBBox(Coord(0), Coord(40, 20, 30)), Occupancy::Free);
  map.fill(CoordBBox(Coord(10, 0, 17), Coord(40, 20, 30)), Occupancy::Unknown);
  std::vector<Coord> layer;
  for (int x = 20; x <= 30; ++x)
    for (int y = 5; y <= 15; ++y) layer.emplace_back(x, y, 16);
  MapProbe probe(map);
  const ViewpointConfig params = intoUnknown();
  // At the layer's height, 2 m off, looking along it: FUEL's rule sees every voxel of it, but the
  // rays toward the unknown above enter the unknown layer about a metre before it.
  const Vec3d level(0.5, 1.0, 1.6);
  const double yaw = 0.0;
  CHECK(countVisible(probe, level, yaw, layer, params.camera) > 100);
  CHECK(countObserved(probe, level, yaw, layer, params) == 0);
  CHECK(bruteObserved(map, layer, params, level, yaw) == 0);
  // From 1 m below, the camera looks up into the unknown above the layer's far part.
  const Vec3d below(0.5, 1.0, 0.6);
  CHECK(countObserved(probe, below, yaw, layer, params) > 20);
  // With unknown_entry_reach_vox 0 a ray must enter the neighbour itself, which slanted rays do
  // not: fewer samples count.
  ViewpointConfig strict = params;
  strict.unknown_entry_reach_vox = 0;
  CHECK(countObserved(probe, below, yaw, layer, strict) < countObserved(probe, below, yaw, layer, params));

  // FUEL's rule with vertical_into_unknown judges this layer, whose unknown lies only above it, as
  // looking into the unknown does; the free voxels beside the unknown's west face (x = 0.9 m,
  // from 1.7 m up) stay FUEL's: seen is enough.
  ViewpointConfig vertical;
  vertical.vertical_into_unknown = true;
  CHECK(countObserved(probe, level, yaw, layer, vertical) == 0);
  CHECK(countObserved(probe, below, yaw, layer, vertical) == countObserved(probe, below, yaw, layer, params));
  std::vector<Coord> face;  // free voxels at x = 0.9 m with unknown beside them, 1.7-2.5 m up
  for (int y = 5; y <= 15; ++y)
    for (int z = 17; z <= 25; ++z) face.emplace_back(9, y, z);
  const Vec3d back(0.2, 1.0, 2.1);
  CHECK(countObserved(probe, back, yaw, face, vertical) == countVisible(probe, back, yaw, face, vertical.camera));
  CHECK(countObserved(probe, back, yaw, face, vertical) > 50);

  SECTION("A cluster of it that no candidate observes gets viewpoints by FUEL's rule, marked so") {
    FrontierCluster cluster;
    cluster.id = 1;
    cluster.voxels = cluster.samples = layer;
    for (const Coord& c : layer) cluster.centroid_W += map.voxelCenter(c) / double(layer.size());
    ViewpointConfig rings_only = intoUnknown();  // rings at the layer's height only: none looks up into the unknown
    rings_only.fallback.enabled = false;
    const std::vector<Viewpoint> views = computeViewpoints(cluster, map, rings_only);
    REQUIRE_FALSE(views.empty());
    for (const Viewpoint& v : views) {
      CHECK_FALSE(v.looks_into_unknown);
      CHECK(v.visible_samples == bruteSeen(map, cluster, rings_only.camera, v));
      CHECK(bruteObserved(map, cluster, rings_only, v) == 0);
    }
    rings_only.voxel_rule_fallback = false;
    CHECK(computeViewpoints(cluster, map, rings_only).empty());
    // The fallback's rings, 0.5 and 1 m lower, look up into the unknown: the first rule's viewpoints.
    const std::vector<Viewpoint> low = computeViewpoints(cluster, map, params);
    REQUIRE_FALSE(low.empty());
    for (const Viewpoint& v : low) {
      CHECK(v.looks_into_unknown);
      CHECK(v.position_W.z() < 1.6 - 0.4);
      CHECK(v.visible_samples == bruteObserved(map, cluster, params, v));
    }
  }
}

TEST_CASE("Viewpoints respect the exploration box and the clearance", "[planner][viewpoint]") {
  const DenseMap map = test::halfKnownRoom();
  FrontierMap frontiers;
  frontiers.rebuild(map);
  REQUIRE_FALSE(frontiers.clusters().empty());
  ViewpointConfig params;
  params.bounds_W = Eigen::AlignedBox3d(Vec3d(0, 0, 0), Vec3d(2.2, 6, 3));  // x <= 2.2 m only
  params.min_clearance_m = 0.5;
  for (const FrontierCluster& cluster : frontiers.clusters())
    for (const Viewpoint& v : computeViewpoints(cluster, map, params)) {
      REQUIRE(v.position_W.x() <= 2.2);
      REQUIRE(test::bruteClear(map, v.position_W, 0.5));
    }
}

TEST_CASE("A cluster seen only through unknown space gets no viewpoint", "[planner][viewpoint]") {
  // A free pocket of 6 x 6 x 6 voxels in unknown space: every ring candidate is in unknown space.
  DenseMap map(0.1, CoordBBox(Coord(-40), Coord(40)));
  map.fill(CoordBBox(Coord(-3), Coord(2)), Occupancy::Free);
  FrontierConfig fp;
  fp.min_cluster_size = 10;
  FrontierMap frontiers(fp);
  frontiers.rebuild(map);
  REQUIRE(frontiers.clusters().size() == 1);
  CHECK(computeViewpoints(frontiers.clusters()[0], map).empty());
}

TEST_CASE("A cluster the rings cannot see from gets the fallback's closer viewpoints", "[planner][viewpoint]") {
  // A 1.5 m cubic alcove (voxels 0..14) walled by occupied voxels, open at x = 1.5 m to unknown
  // space: its frontier is the 15 x 15 voxel plane x = 1.4 m. Every ring candidate 1.5-2.5 m
  // from the plane's centre lies in the walls or the unknown; the fallback rings start at 0.5 m.
  DenseMap map(0.1, CoordBBox(Coord(-30), Coord(45)));
  map.fill(CoordBBox(Coord(-1), Coord(15)), Occupancy::Occupied);
  map.fill(CoordBBox(Coord(0), Coord(14)), Occupancy::Free);
  map.fill(CoordBBox(Coord(15, 0, 0), Coord(15, 14, 14)), Occupancy::Unknown);
  FrontierMap frontiers;
  frontiers.rebuild(map);
  REQUIRE(frontiers.clusters().size() == 1);
  const FrontierCluster& cluster = frontiers.clusters()[0];
  REQUIRE(cluster.voxels.size() == 15u * 15u);

  ViewpointConfig rings_only;
  rings_only.fallback.enabled = false;
  CHECK(computeViewpoints(cluster, map, rings_only).empty());

  const ViewpointConfig params;
  const ViewpointFallback& fb = params.fallback;
  const std::vector<Viewpoint> views = computeViewpoints(cluster, map, params);
  REQUIRE_FALSE(views.empty());
  const int fraction_needed = int(std::ceil(fb.min_visible_fraction * double(cluster.samples.size())));
  for (const Viewpoint& v : views) {
    REQUIRE(test::bruteClear(map, v.position_W, fb.min_clearance_m));
    const int seen = bruteSeen(map, cluster, params.camera, v);
    REQUIRE(seen == v.visible_samples);
    REQUIRE((seen > fb.minVisibleSamples(cluster) || seen >= fraction_needed));
    // On one of the fallback's rings, at one of its heights.
    const double r = (v.position_W - cluster.centroid_W).head<2>().norm();
    bool on_ring = false;
    for (int k = 0; k < fb.ring_count; ++k)
      on_ring |= std::abs(r - (fb.ring_radius_min_m + (fb.ring_radius_max_m - fb.ring_radius_min_m) * k /
                                                          (fb.ring_count - 1))) < 1e-9;
    REQUIRE(on_ring);
    const double dz = v.position_W.z() - cluster.centroid_W.z();
    REQUIRE(std::any_of(fb.height_offsets_m.begin(), fb.height_offsets_m.end(),
                        [&](double h) { return std::abs(h - dz) < 1e-9; }));
  }
}

TEST_CASE("The fallback's threshold lets a small cluster pass by the fraction it sees", "[planner][viewpoint]") {
  // The frontier of the halfKnownRoom, cut down to a 4 x 4 voxel patch: 4 samples, far fewer than
  // min_visible_samples. Standing in the known half, a camera sees all of them.
  DenseMap map = test::halfKnownRoom();
  map.fill(CoordBBox(Coord(40, 0, 0), Coord(82, 62, 32)), Occupancy::Occupied);
  map.fill(CoordBBox(Coord(40, 28, 12), Coord(40, 31, 15)), Occupancy::Unknown);
  FrontierConfig fp;
  fp.min_cluster_size = 1;
  FrontierMap frontiers(fp);
  frontiers.rebuild(map);
  REQUIRE(frontiers.clusters().size() == 1);
  const FrontierCluster& cluster = frontiers.clusters()[0];
  REQUIRE(cluster.samples.size() < std::size_t(ViewpointConfig{}.min_visible_samples));

  ViewpointConfig rings_only;
  rings_only.fallback.enabled = false;
  CHECK(computeViewpoints(cluster, map, rings_only).empty());  // 4 samples never exceed 15
  ViewpointConfig params;
  const std::vector<Viewpoint> views = computeViewpoints(cluster, map, params);
  REQUIRE_FALSE(views.empty());
  CHECK(views.front().visible_samples == int(cluster.samples.size()));
  for (const Viewpoint& v : views)
    CHECK(v.visible_samples >= int(std::ceil(params.fallback.min_visible_fraction * double(cluster.samples.size()))));
  params.fallback.min_visible_fraction = 1.0;
  for (const Viewpoint& v : computeViewpoints(cluster, map, params))
    CHECK(v.visible_samples == int(cluster.samples.size()));
}

TEST_CASE("A large cluster seen only a few voxels at a time gets fallback viewpoints at a lower threshold",
          "[planner][viewpoint]") {
  const DenseMap map = test::slotBehindPlate();
  FrontierConfig fp;
  fp.min_cluster_size = 1;
  fp.split_radius_xy_m = 5.0;  // one cluster, not split
  FrontierMap frontiers(fp);
  frontiers.rebuild(map);
  REQUIRE(frontiers.clusters().size() == 1);
  const FrontierCluster& cluster = frontiers.clusters()[0];
  ViewpointConfig params;
  params.fallback.large_min_visible_samples = params.fallback.min_visible_samples;  // one threshold: 15
  // Half the cluster is more than FUEL's 15: the fraction does not lower the threshold here.
  REQUIRE(int(std::ceil(params.fallback.min_visible_fraction * double(cluster.samples.size()))) >
          params.fallback.min_visible_samples);
  CHECK(computeViewpoints(cluster, map, params).empty());

  ViewpointConfig low = params;
  low.fallback.min_visible_samples = 2;
  const std::vector<Viewpoint> views = computeViewpoints(cluster, map, low);
  REQUIRE_FALSE(views.empty());
  for (const Viewpoint& v : views) {
    REQUIRE(test::bruteClear(map, v.position_W, params.fallback.min_clearance_m));
    const int seen = bruteSeen(map, cluster, params.camera, v);
    REQUIRE(seen == v.visible_samples);
    REQUIRE(seen > 2);
    REQUIRE(seen <= ViewpointConfig{}.min_visible_samples);  // a look at a time, through the gap
    REQUIRE(v.position_W.x() < 3.7);                         // on the room's side of the plate
  }

  // The lower threshold for large clusters only: this cluster gets the same viewpoints when its
  // size reaches large_cluster_voxels, and none when it falls one voxel short.
  ViewpointConfig large = params;
  large.fallback.large_min_visible_samples = 2;
  large.fallback.large_cluster_voxels = int(cluster.voxels.size());
  const std::vector<Viewpoint> large_views = computeViewpoints(cluster, map, large);
  REQUIRE(large_views.size() == views.size());
  for (std::size_t k = 0; k < views.size(); ++k) {
    CHECK(large_views[k].position_W == views[k].position_W);
    CHECK(large_views[k].visible_samples == views[k].visible_samples);
  }
  large.fallback.large_cluster_voxels = int(cluster.voxels.size()) + 1;
  CHECK(computeViewpoints(cluster, map, large).empty());
}

TEST_CASE("ViewpointConfig::validate names the field", "[planner][viewpoint]") {
  ViewpointConfig p;
  p.ring_radius_max_m = 1.0;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("ring_radius_max_m"));
  p = ViewpointConfig{};
  p.camera.max_range_m = 0.0;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("max_range_m"));
  p = ViewpointConfig{};
  p.height_offsets_m.clear();
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("height_offsets_m"));
  p = ViewpointConfig{};
  p.fallback.min_visible_fraction = 0.0;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("ViewpointFallback.min_visible_fraction"));
  p = ViewpointConfig{};
  p.fallback.ring_radius_min_m = 3.0;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("ViewpointFallback.ring_radius_max_m"));
  p = ViewpointConfig{};
  p.fallback.min_visible_samples = -1;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("ViewpointFallback.min_visible_samples"));
  p = ViewpointConfig{};
  p.fallback.large_cluster_voxels = 0;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("ViewpointFallback.large_cluster_voxels"));
  p = ViewpointConfig{};
  p.fallback.large_min_visible_samples = -1;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("ViewpointFallback.large_min_visible_samples"));
  p = ViewpointConfig{};
  p.unknown_entry_reach_vox = -1;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("unknown_entry_reach_vox"));
  p = ViewpointConfig{};
  p.frontier_bounds_W = Eigen::AlignedBox3d();  // empty
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("frontier_bounds_W"));
}
