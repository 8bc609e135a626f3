// Active loop closure, the loop-closing clusters over synthetic histories: runs of consecutive
// viewpoints end at a jump, at the size bound and at the extent bound; only old viewpoints are
// clustered; runs near an existing centre join it; and a flight's clusters keep the invariants.
#include "vdbmap/planner/loop_clusters.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace vdbmap;
using namespace vdbmap::planner;

namespace {
/// A history that records every pose offered, one per second from t0_s.
ViewpointHistory historyOf(const std::vector<Vec3d>& positions, double t0_s = 0.0) {
  ViewpointHistoryConfig every;
  every.record_spacing_m = 0.0;
  ViewpointHistory h(every);
  for (std::size_t i = 0; i < positions.size(); ++i) h.offer(positions[i], 0.0, t0_s + double(i));
  return h;
}

std::vector<Vec3d> line(int n, double step_m, double y = 0.0) {
  std::vector<Vec3d> p;
  for (int i = 0; i < n; ++i) p.push_back(Vec3d(step_m * i, y, 1.0));
  return p;
}

LoopClusterConfig smallParams() {
  LoopClusterConfig p;
  p.min_age_s = 10.0;
  p.max_viewpoints = 4;
  p.max_extent_m = 1.0;
  p.link_distance_m = 0.5;
  p.merge_distance_m = 0.0;  // no merging unless a test asks for it
  return p;
}

using Indices = std::vector<std::size_t>;
}  // namespace

TEST_CASE("Runs of consecutive viewpoints end at a jump, at the size bound and at the extent bound", "[planner][alc]") {
  LoopClusterConfig p = smallParams();
  SECTION("size bound: at most max_viewpoints per run") {
    const ViewpointHistory h = historyOf(line(10, 0.125));  // exact in binary: ties are real ties
    LoopClusters c(p);
    CHECK(c.update(h, 100.0) == 2);
    REQUIRE(c.size() == 2);
    CHECK(c[0].centre == 2);                     // the middle of run {0, 1, 2, 3}
    CHECK(c[0].members == Indices{2, 1, 3, 0});  // centre first, then by distance to it (ties: older)
    CHECK(c[1].centre == 6);
    CHECK(c[1].members == Indices{6, 5, 7, 4});
    CHECK(c.openRun() == Indices{8, 9});  // not a cluster until the next viewpoint ends it
    CHECK_FALSE(c.clusterOf(8));
    CHECK(c.clusterOf(3) == std::optional<LoopClusterId>(0));
    CHECK(c.taken() == 10);
  }
  SECTION("extent bound: a run stays within max_extent_m of its first viewpoint") {
    p.max_viewpoints = 100;
    const ViewpointHistory h = historyOf(line(12, 0.25));  // x = 0, 0.25, ..., 2.75
    LoopClusters c(p);
    CHECK(c.update(h, 100.0) == 2);
    REQUIRE(c.size() == 2);
    CHECK(c[0].members.size() == 5);  // x = 0 .. 1.0 (exactly max_extent_m is in); 1.25 is not
    CHECK(c[0].centre == 2);
    CHECK(c[1].centre == 7);  // run x = 1.25 .. 2.25
    CHECK(c.openRun() == Indices{10, 11});
  }
  SECTION("a jump larger than link_distance_m ends a run") {
    std::vector<Vec3d> pts = line(3, 0.125);
    pts.push_back(Vec3d(5, 0, 1));
    pts.push_back(Vec3d(5.125, 0, 1));
    const ViewpointHistory h = historyOf(pts);
    LoopClusters c(p);
    CHECK(c.update(h, 100.0) == 1);
    REQUIRE(c.size() == 1);
    CHECK(c[0].members == Indices{1, 0, 2});
    CHECK(c.openRun() == Indices{3, 4});
  }
  SECTION("bad parameters name the field") {
    p.max_extent_m = 0.0;
    CHECK_THROWS_WITH(LoopClusters(p), Catch::Contains("max_extent_m"));
  }
}

TEST_CASE("Only viewpoints at least min_age_s old are clustered", "[planner][alc]") {
  const ViewpointHistory h = historyOf(line(10, 0.125));  // stamps 0 .. 9 s
  LoopClusters c(smallParams());                          // min age 10 s
  CHECK(c.update(h, 9.5) == 0);
  CHECK(c.taken() == 0);
  CHECK(c.update(h, 12.0) == 0);  // stamps <= 2 s: the open run {0, 1, 2}
  CHECK(c.taken() == 3);
  CHECK(c.size() == 0);
  CHECK(c.update(h, 14.0) == 1);  // stamp 4 s ends the run {0 .. 3}
  CHECK(c.taken() == 5);
  REQUIRE(c.size() == 1);
  for (const std::size_t m : c[0].members) CHECK(h[m].stamp_s <= 14.0 - 10.0);
  CHECK(c.update(h, 14.0) == 0);
  CHECK_THROWS_AS(c.update(historyOf(line(2, 0.125)), 20.0), std::invalid_argument);
}

TEST_CASE("Runs whose centre is near an existing cluster's join it, far ones start a new cluster", "[planner][alc]") {
  LoopClusterConfig p = smallParams();
  p.merge_distance_m = 0.6;
  // A first pass along y = 0 (x = 0 .. 2.75 m), a place far away, a second pass along y = 0.25,
  // and a last far pose that ends the second pass's last run. Runs are 4 viewpoints (0.75 m).
  std::vector<Vec3d> pts = line(12, 0.25);
  pts.push_back(Vec3d(10, 10, 1));
  const std::size_t second = pts.size();
  for (const Vec3d& q : line(12, 0.25, 0.25)) pts.push_back(q);
  pts.push_back(Vec3d(20, 20, 1));
  const ViewpointHistory h = historyOf(pts);
  LoopClusters c(p);
  CHECK(c.update(h, 100.0) == 7);  // three runs per pass, and the far place
  REQUIRE(c.size() == 4);
  for (LoopClusterId id = 0; id < 3; ++id) {
    CHECK(c[id].runs == 2);                        // each second-pass run joined its twin
    CHECK(h[c[id].centre].position_W.y() == 0.0);  // the cluster keeps its first centre
    CHECK(c[id].members.size() == 4);              // of 8 candidates: size-bounded
    const Vec3d centre = h[c[id].centre].position_W;
    for (std::size_t k = 1; k + 1 < c[id].members.size(); ++k)
      CHECK((h[c[id].members[k]].position_W - centre).norm() <= (h[c[id].members[k + 1]].position_W - centre).norm());
  }
  CHECK(c[3].runs == 1);
  CHECK(c[3].members == Indices{12});
  // Around cluster 0's centre (x = 0.5): x = 0.25 and 0.75 of the first pass and the second
  // pass's centre straight across (0.25 m away each; ties go to the older) made it in; the first
  // pass's x = 0 (0.5 m away) and the second pass's x = 0 were pushed out by the size bound.
  CHECK(c[0].members == Indices{2, 1, 3, second + 2});
  CHECK_FALSE(c.clusterOf(0));
  CHECK_FALSE(c.clusterOf(second));
  CHECK(c.clusterOf(second + 2) == std::optional<LoopClusterId>(0));
  // Distinct places stay distinct: no two centres within the merge distance.
  for (LoopClusterId a = 0; a < c.size(); ++a)
    for (LoopClusterId b = a + 1; b < c.size(); ++b)
      CHECK((h[c[a].centre].position_W - h[c[b].centre].position_W).norm() > p.merge_distance_m);
}

TEST_CASE("A flight's clusters keep their invariants; near() equals brute force; corrections move them",
          "[planner][alc]") {
  // Two laps of an 8 x 6 m rectangle at 1 m/s (the second 0.1 m higher), poses offered at 20 Hz.
  ViewpointHistory h;
  const std::vector<Vec3d> corners{Vec3d(0, 0, 1), Vec3d(8, 0, 1), Vec3d(8, 6, 1), Vec3d(0, 6, 1)};
  double t = 0.0, second_lap_s = 0.0;
  for (int lap = 0; lap < 2; ++lap) {
    second_lap_s = t;
    for (std::size_t k = 0; k < corners.size(); ++k) {
      const Vec3d a = corners[k], b = corners[(k + 1) % corners.size()], dir = (b - a).normalized();
      for (double s = 0.0; s < (b - a).norm(); s += 0.05, t += 0.05)
        h.offer(a + s * dir + Vec3d(0, 0, 0.1 * lap), std::atan2(dir.y(), dir.x()), t);
    }
  }
  const LoopClusterConfig p;  // defaults
  LoopClusters c(p);
  const double now_s = t + p.min_age_s;  // everything flown is old enough
  c.update(h, now_s);
  REQUIRE(c.size() >= 10);
  std::size_t both_laps = 0;
  for (const LoopCluster& cl : c.clusters()) {
    REQUIRE_FALSE(cl.members.empty());
    CHECK(cl.members.front() == cl.centre);
    CHECK(cl.members.size() <= std::size_t(p.max_viewpoints));
    const Vec3d centre = h[cl.centre].position_W;
    for (const std::size_t m : cl.members) {
      CHECK(h[m].stamp_s <= now_s - p.min_age_s);
      CHECK(c.clusterOf(m) == std::optional<LoopClusterId>(cl.id));
      // A member lies within 2 max_extent_m of its run's centre, which is within merge_distance_m.
      CHECK((h[m].position_W - centre).norm() <= p.merge_distance_m + 2.0 * p.max_extent_m);
    }
    for (const LoopCluster& other : c.clusters())
      if (other.id > cl.id) CHECK((h[other.centre].position_W - centre).norm() > p.merge_distance_m);
    bool first = false, second = false;
    for (const std::size_t m : cl.members) (h[m].stamp_s < second_lap_s ? first : second) = true;
    both_laps += first && second ? 1 : 0;
  }
  CHECK(both_laps * 2 >= c.size());  // the second lap came back to the first lap's places

  auto bruteNear = [&](const Vec3d& q, double r) {
    std::vector<LoopClusterId> ids;
    for (const LoopCluster& cl : c.clusters())
      for (const std::size_t m : cl.members)
        if ((h[m].position_W - q).norm() <= r) {
          ids.push_back(cl.id);
          break;
        }
    return ids;
  };
  for (const Vec3d& q : {Vec3d(0, 0, 1), Vec3d(4, 3, 1), Vec3d(8, 6, 1.1), Vec3d(4, 0, 1.5)})
    for (const double r : {0.5, 3.0, 6.0}) CHECK(c.near(h, q, r) == bruteNear(q, r));

  // A correction lifts every viewpoint by 1 m: centres follow, membership stays.
  const std::vector<LoopCluster> before = c.clusters();
  h.correct([](const FlownViewpoint& v) { return FlatPose{v.position_W + Vec3d(0, 0, 1), v.yaw_rad}; });
  c.refresh(h);
  for (LoopClusterId id = 0; id < c.size(); ++id) {
    CHECK(c[id].centre == before[id].centre);
    CHECK(c[id].members.size() == before[id].members.size());
  }
  CHECK(c.near(h, Vec3d(0, 0, 2), 0.5) == bruteNear(Vec3d(0, 0, 2), 0.5));
  CHECK(c.near(h, Vec3d(0, 0, 0), 0.5).empty());
}
