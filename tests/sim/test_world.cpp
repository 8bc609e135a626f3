// Simulated worlds (sim/world.hpp): loading the shared worlds, exact rays and distances checked
// against brute force, and meshes with holes and degenerate faces.
#include <catch2/catch.hpp>

#include "sim/sim_test_helpers.hpp"
#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/triangle_geometry.hpp"

#include <cmath>
#include <random>

using namespace vdbmap;
using namespace vdbmap::sim;

namespace {
/// Brute force: the nearest hit of a ray over every triangle (Moller-Trumbore).
double bruteRay(const TriangleMesh& m, const Vec3d& o, const Vec3d& d, double t_max) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& t : m.triangles) {
    const Vec3d a = m.vertices[std::size_t(t[0])].cast<double>(), e1 = m.vertices[std::size_t(t[1])].cast<double>() - a,
                e2 = m.vertices[std::size_t(t[2])].cast<double>() - a;
    const Vec3d p = d.cross(e2);
    const double det = e1.dot(p);
    if (det == 0.0) continue;
    const Vec3d s = o - a, q = s.cross(e1);
    const double u = s.dot(p) / det, v = d.dot(q) / det, th = e2.dot(q) / det;
    if (u >= 0 && v >= 0 && u + v <= 1 && th > 1e-9 && th <= t_max) best = std::min(best, th);
  }
  return best;
}
double bruteDistance(const TriangleMesh& m, const Vec3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& t : m.triangles)
    best = std::min(best, (p - closestPointOnTriangle(p, m.vertices[std::size_t(t[0])].cast<double>(),
                                                      m.vertices[std::size_t(t[1])].cast<double>(),
                                                      m.vertices[std::size_t(t[2])].cast<double>()))
                              .norm());
  return best;
}
}  // namespace

TEST_CASE("the house world loads: 19 x 11.4 x 3 m, a floor and no roof unless capped", "[sim][world]") {
  const World world = World::load(test::houseMesh());
  CHECK(world.stats().triangles_in == 145696);
  CHECK(world.stats().triangles + world.stats().degenerate_dropped == 145696);
  const Vec3d size = world.bounds().sizes();
  CHECK(size.x() == Approx(19.0).margin(0.1));
  CHECK(size.y() == Approx(11.4).margin(0.1));
  CHECK(size.z() == Approx(3.0).margin(0.05));
  // From the middle of the house, straight down meets the floor; up, nothing: the shared mesh has
  // no ceiling (despite its PROVENANCE.md), so the world can be capped at 3 m.
  const Vec3d centre(0.0, 0.0, 1.0);
  REQUIRE(world.isClear(centre, 0.4));
  CHECK(world.raycast(centre, -Vec3d::UnitZ(), 10.0).t == Approx(1.0).margin(0.05));
  CHECK_FALSE(world.raycast(centre, Vec3d::UnitZ(), 10.0).hit());
  WorldConfig capped;
  capped.ceiling_clip_z_m = 3.0;
  capped.cap_ceiling = true;
  const World closed = World::load(test::houseMesh(), capped);
  CHECK(closed.stats().capped);
  CHECK(closed.raycast(centre, Vec3d::UnitZ(), 10.0).t == Approx(2.0).margin(1e-9));
  CHECK(closed.bounds().sizes().x() == Approx(size.x()));
}

TEST_CASE("rays and distances on the warehouse match brute force over every triangle", "[sim][world]") {
  // The warehouse has 10 m walls and no roof: clipped at 3 m, nothing is left above.
  WorldConfig config;
  config.ceiling_clip_z_m = 3.0;
  const World world = World::load(test::warehouseMesh(), config);
  CHECK(world.bounds().max().z() <= 3.0 + 1e-6);
  CHECK(world.stats().triangles > 10000);
  const World unclipped = World::load(test::warehouseMesh());
  CHECK(unclipped.bounds().max().z() > 9.0);
  const Vec3d inside(0.0, 0.0, 1.0);
  CHECK_FALSE(world.raycast(inside, Vec3d::UnitZ(), 20.0).hit());  // open to the sky below 3 m
  const TriangleMesh& m = world.mesh();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> ux(-7, 7), uy(-10.5, 10.5), uz(0.2, 2.8), u(-1, 1);
  int hits = 0;
  for (int k = 0; k < 60; ++k) {
    const Vec3d o(ux(rng), uy(rng), uz(rng));
    const Vec3d d = Vec3d(u(rng), u(rng), 0.5 * u(rng)).normalized();
    const double expected = bruteRay(m, o, d, 30.0);
    const RayHit hit = world.raycast(o, d, 30.0);
    CAPTURE(k, o.transpose(), d.transpose());
    if (std::isfinite(expected)) {
      ++hits;
      REQUIRE(hit.hit());
      CHECK(hit.t == Approx(expected).margin(1e-6));
    } else {
      CHECK_FALSE(hit.hit());
    }
    CHECK(world.distance(o, 100.0) == Approx(bruteDistance(m, o)).margin(1e-9));
    const double capped = world.distance(o, 0.3);
    CHECK(capped == Approx(std::min(0.3, bruteDistance(m, o))).margin(1e-9));
  }
  CHECK(hits > 30);
}

TEST_CASE("a mesh with holes and degenerate faces: the bad faces are dropped, the hole lets rays through",
          "[sim][world]") {
  TriangleMesh m;
  test::addBox(m, {-1, -1, -1}, {1, 1, 1}, /*skip_face=*/1);  // open at +x
  const int n = int(m.vertices.size());
  m.vertices.emplace_back(5.0f, 5.0f, 5.0f);
  m.vertices.emplace_back(6.0f, 6.0f, 6.0f);
  m.vertices.emplace_back(7.0f, 7.0f, 7.0f);  // collinear with the two before
  m.vertices.emplace_back(NAN, 0.0f, 0.0f);
  m.triangles.emplace_back(0, 0, 1);          // repeated vertex
  m.triangles.emplace_back(n, n + 1, n + 2);  // collinear: zero area
  m.triangles.emplace_back(0, 1, n + 3);      // a NaN vertex
  m.triangles.emplace_back(0, 1, 999);        // index out of range
  const World world(m);
  CHECK(world.stats().triangles == 10);
  CHECK(world.stats().degenerate_dropped == 4);
  // The bounds come from the kept faces only (not the stray vertices).
  CHECK(world.bounds().max().x() == Approx(1.0));
  const Vec3d centre = Vec3d::Zero();
  CHECK(world.raycast(centre, -Vec3d::UnitX(), 10.0).t == Approx(1.0));
  CHECK_FALSE(world.raycast(centre, Vec3d::UnitX(), 10.0).hit());                // out through the hole
  CHECK(world.raycast(Vec3d(3, 0, 0), -Vec3d::UnitX(), 10.0).t == Approx(4.0));  // in through it
  CHECK(world.distance(centre, 5.0) == Approx(1.0));
  // From (1.5, 0, 0) the nearest points are the open box's rim edges at x = 1: 0.5 m away.
  CHECK(world.distance(Vec3d(1.5, 0, 0), 5.0) == Approx(std::hypot(0.5, 1.0)).margin(1e-9));
  CHECK(world.isSegmentClear(Vec3d(-0.5, 0, 0), Vec3d(3, 0, 0), 0.4));         // out through the hole
  CHECK_FALSE(world.isSegmentClear(Vec3d(-0.5, 0, 0), Vec3d(-3, 0, 0), 0.4));  // through the wall

  TriangleMesh only_bad;
  only_bad.vertices = {Vec3f(0, 0, 0), Vec3f(1, 1, 1)};
  only_bad.triangles = {{0, 1, 1}};
  CHECK_THROWS_WITH(World(only_bad), Catch::Contains("no usable triangle"));
}

TEST_CASE("a ceiling clip splits straddling triangles exactly at the height", "[sim][world]") {
  TriangleMesh wall;  // a vertical wall 0..4 m high at x = 2
  wall.vertices = {Vec3f(2, -1, 0), Vec3f(2, 1, 0), Vec3f(2, 1, 4), Vec3f(2, -1, 4)};
  wall.triangles = {{0, 1, 2}, {0, 2, 3}};
  WorldConfig config;
  config.ceiling_clip_z_m = 2.5;
  const World world(wall, config);
  CHECK(world.bounds().max().z() == Approx(2.5));
  CHECK(world.raycast(Vec3d(0, 0, 2.4), Vec3d::UnitX(), 5.0).t == Approx(2.0));
  CHECK_FALSE(world.raycast(Vec3d(0, 0, 2.6), Vec3d::UnitX(), 5.0).hit());
  config.ceiling_clip_z_m = -1.0;
  CHECK_THROWS_WITH(World(wall, config), Catch::Contains("above the ceiling clip"));
}
