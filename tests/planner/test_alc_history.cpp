// Active loop closure, the history: the incremental KD-tree answers radius queries exactly as brute
// force does (while it grows, on the sphere's surface, after a reset), and the viewpoint history
// records a pose only when the vehicle moved or turned enough.
#include "vdbmap/planner/point_index.hpp"
#include "vdbmap/planner/viewpoint_history.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <random>

using namespace vdbmap;
using namespace vdbmap::planner;

namespace {
/// The reference: every point with dx^2 + dy^2 + dz^2 <= r^2, ascending.
std::vector<std::size_t> bruteWithin(const std::vector<Vec3d>& points, const Vec3d& c, double r) {
  std::vector<std::size_t> hits;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double dx = points[i].x() - c.x(), dy = points[i].y() - c.y(), dz = points[i].z() - c.z();
    if (dx * dx + dy * dy + dz * dz <= r * r) hits.push_back(i);
  }
  return hits;
}
}  // namespace

TEST_CASE("PointIndex radius queries equal brute force while the index grows", "[planner][alc]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coord(-10.0, 10.0), radius(0.0, 4.0);
  std::normal_distribution<double> step(0.0, 0.3);
  PointIndex index;
  std::vector<Vec3d> points;
  CHECK(index.withinRadius(Vec3d::Zero(), 5.0).empty());
  Vec3d walker = Vec3d::Zero();
  std::size_t queries = 0, hits = 0;
  for (int i = 0; i < 3000; ++i) {
    // Half a random walk (dense, like a flight), half uniform points, and some exact duplicates.
    if (i % 2 == 0) walker += Vec3d(step(rng), step(rng), 0.2 * step(rng));
    const Vec3d p = i % 7 == 0 && !points.empty() ? points[points.size() / 2]
                                                  : (i % 2 == 0 ? walker : Vec3d(coord(rng), coord(rng), coord(rng)));
    REQUIRE(index.add(p) == points.size());
    points.push_back(p);
    if (i % 37 == 0) {
      for (int q = 0; q < 10; ++q) {
        const Vec3d c =
            q % 2 == 0 ? points[std::size_t(rng()) % points.size()] : Vec3d(coord(rng), coord(rng), coord(rng));
        const double r = radius(rng);
        const std::vector<std::size_t> expected = bruteWithin(points, c, r);
        REQUIRE(index.withinRadius(c, r) == expected);
        ++queries;
        hits += expected.size();
      }
    }
  }
  CHECK(index.size() == points.size());
  CHECK(queries == 820);
  CHECK(hits > 10 * queries);  // the queries are not trivially empty
}

TEST_CASE("PointIndex includes points exactly on the sphere and follows a reset", "[planner][alc]") {
  PointIndex index;
  for (int i = 0; i < 40; ++i) index.add(Vec3d(0.5 * i, 0.0, 0.0));
  // 0.5 * i is exact in binary: points at distance exactly 2 from x = 3 are x = 1 and x = 5.
  CHECK(index.withinRadius(Vec3d(3, 0, 0), 2.0) == std::vector<std::size_t>{2, 3, 4, 5, 6, 7, 8, 9, 10});
  CHECK(index.withinRadius(Vec3d(3, 0, 0), 0.0) == std::vector<std::size_t>{6});
  CHECK(index.withinRadius(Vec3d(3, 0, 0.1), 0.0).empty());
  CHECK_THROWS_AS(index.withinRadius(Vec3d::Zero(), -1.0), std::invalid_argument);
  CHECK_THROWS_AS(index.add(Vec3d(NAN, 0, 0)), std::invalid_argument);

  std::vector<Vec3d> moved;
  for (int i = 0; i < 40; ++i) moved.push_back(Vec3d(0.0, 0.5 * i, 0.0));
  index.reset(moved);
  CHECK(index.size() == 40);
  CHECK(index.withinRadius(Vec3d(3, 0, 0), 2.0).empty());
  CHECK(index.withinRadius(Vec3d(0, 3, 0), 0.5) == std::vector<std::size_t>{5, 6, 7});
  CHECK(index.add(Vec3d(0, 3, 0)) == 40);  // it keeps growing after a reset
  CHECK(index.withinRadius(Vec3d(0, 3, 0), 0.0) == std::vector<std::size_t>{6, 40});
}

TEST_CASE("ViewpointHistory records a pose when the vehicle moved or turned enough", "[planner][alc]") {
  ViewpointHistoryConfig p;  // 0.25 m, 0.1 rad
  ViewpointHistory h(p);
  CHECK(h.offer(Vec3d(0, 0, 1), 0.0, 0.0));                  // the first is always recorded
  CHECK_FALSE(h.offer(Vec3d(0.2, 0, 1), 0.05, 0.1));         // 0.2 m, 0.05 rad: hovering about
  CHECK(h.offer(Vec3d(0.25, 0, 1), 0.0, 0.2));               // moved 0.25 m from the last recorded
  CHECK_FALSE(h.offer(Vec3d(0.25, 0, 1), 0.0, 0.2));         // the same stamp again is fine
  CHECK(h.offer(Vec3d(0.25, 0, 1), -0.1, 0.3));              // turned 0.1 rad
  CHECK(h.offer(Vec3d(0.25, 0, 1), 2.0 * M_PI + 1.0, 0.4));  // yaw stored wrapped
  REQUIRE(h.size() == 4);
  CHECK(h[3].yaw_rad == Approx(1.0));
  CHECK(h[1].stamp_s == 0.2);
  CHECK_THROWS_AS(h.offer(Vec3d(5, 0, 1), 0.0, 0.35), std::invalid_argument);  // back in time
  CHECK_THROWS_AS(h.offer(Vec3d(5, 0, NAN), 0.0, 1.0), std::invalid_argument);
  ViewpointHistoryConfig bad;
  bad.record_yaw_step_rad = 0.0;
  CHECK_THROWS_WITH(ViewpointHistory(bad), Catch::Contains("record_yaw_step_rad"));
}

TEST_CASE("ViewpointHistory radius queries over a flight equal brute force, before and after a correction",
          "[planner][alc]") {
  ViewpointHistory h;
  // Two laps of a 6 x 4 m rectangle at 1 m/s, offered at 20 Hz, slowly climbing.
  const std::vector<Vec3d> corners{Vec3d(0, 0, 1), Vec3d(6, 0, 1), Vec3d(6, 4, 1), Vec3d(0, 4, 1)};
  double t = 0.0;
  for (int lap = 0; lap < 2; ++lap)
    for (std::size_t c = 0; c < corners.size(); ++c) {
      const Vec3d a = corners[c], b = corners[(c + 1) % corners.size()];
      const Vec3d dir = (b - a).normalized();
      for (double s = 0.0; s < (b - a).norm(); s += 0.05, t += 0.05)
        h.offer(a + s * dir + Vec3d(0, 0, 0.01 * t), std::atan2(dir.y(), dir.x()), t);
    }
  REQUIRE(h.size() > 150);
  auto positions = [&] {
    std::vector<Vec3d> p;
    for (const FlownViewpoint& v : h.viewpoints()) p.push_back(v.position_W);
    return p;
  };
  for (const Vec3d& c : {Vec3d(0, 0, 1), Vec3d(3, 2, 1.2), Vec3d(6, 4, 1.5), Vec3d(10, 10, 1)})
    for (const double r : {0.3, 1.0, 3.0}) CHECK(h.withinRadius(c, r) == bruteWithin(positions(), c, r));

  // A correction shifts everything recorded after t = 10 s by 0.5 m in y.
  const FlownViewpoint first = h[0], last = h[h.size() - 1];
  h.correct([](const FlownViewpoint& v) {
    return FlatPose{v.position_W + Vec3d(0, v.stamp_s > 10.0 ? 0.5 : 0.0, 0), v.yaw_rad};
  });
  CHECK(h[0].position_W == first.position_W);
  CHECK(h[h.size() - 1].position_W == last.position_W + Vec3d(0, 0.5, 0));
  CHECK(h[h.size() - 1].stamp_s == last.stamp_s);
  for (const Vec3d& c : {Vec3d(0, 0.5, 1.5), Vec3d(3, 2, 1.2)})
    for (const double r : {0.3, 1.0, 3.0}) CHECK(h.withinRadius(c, r) == bruteWithin(positions(), c, r));
  CHECK_THROWS_AS(h.correct([](const FlownViewpoint&) {
    return FlatPose{Vec3d(NAN, 0, 0), 0.0};
  }),
                  std::invalid_argument);
  CHECK(h[h.size() - 1].position_W == last.position_W + Vec3d(0, 0.5, 0));  // a failed correction changes nothing
}
