// The observable surface and coverage: what counts as observable in a room with two boxes (hand
// computed areas), what is excluded (under the boxes, outside the exploration box, unreachable
// rooms), and coverage against synthetic maps (brute-force reference).
#include "sim/sim_test_helpers.hpp"

#include "vdbmap/planner/dense_map.hpp"
#include "vdbmap/sim/surface_coverage.hpp"

#include <catch2/catch.hpp>

using namespace vdbmap;
using namespace vdbmap::sim;
using openvdb::Coord;
using openvdb::CoordBBox;

namespace {
/// Area per sample varies with the random rounding per triangle: compare areas within 3 %.
constexpr double kAreaTolerance = 0.03;

SurfaceCoverageConfig fastConfig() {
  SurfaceCoverageConfig c;
  c.sample_spacing_m = 0.05;
  return c;
}
}  // namespace

TEST_CASE("sampleSurface spreads samples by area, on the triangles", "[sim][coverage]") {
  TriangleMesh m;
  test::addBox(m, Vec3d(0, 0, 0), Vec3d(2, 1, 0.5));
  const double area = 2.0 * (2.0 * 1.0 + 2.0 * 0.5 + 1.0 * 0.5);
  const std::vector<Vec3d> s = sampleSurface(m, 0.05, 7);
  CHECK(double(s.size()) * 0.05 * 0.05 == Approx(area).epsilon(kAreaTolerance));
  for (const Vec3d& p : s) {
    const double to_face = std::min({p.x(), 2 - p.x(), p.y(), 1 - p.y(), p.z(), 0.5 - p.z()});
    CHECK(std::abs(to_face) < 1e-6);
  }
  CHECK(sampleSurface(m, 0.05, 7) == s);  // seeded
}

TEST_CASE("The observable surface of a room with two boxes excludes what no camera can see", "[sim][coverage]") {
  // roomWithBox: a 6 x 4 x 2.5 m room; box A [1,2]x[-1.5,-0.5]x[0,1.2], box B [-2.2,-1.6]x[0.8,1.6]x[0,1.8].
  const World world(test::roomWithBox());
  const Eigen::AlignedBox3d box(Vec3d(-3, -2, 0), Vec3d(3, 2, 2.5));
  const ObservableSurface obs(world, box, Vec3d(0, 0, 1.2), fastConfig());
  // Observable: floor minus the boxes' footprints, ceiling, walls, the boxes' sides and tops.
  const double floor = 24.0 - 1.0 - 0.48, ceiling = 24.0, walls = 2 * (6 + 4) * 2.5;
  const double box_a = 4 * 1.0 * 1.2 + 1.0, box_b = 2 * (0.6 + 0.8) * 1.8 + 0.48;
  CHECK(obs.stats().observable_area_m2 == Approx(floor + ceiling + walls + box_a + box_b).epsilon(kAreaTolerance));
  CHECK(obs.stats().reachable_cells > 0);
  // Nothing observable lies under a box (the floor there and the boxes' bottoms).
  for (const Vec3d& p : obs.samples()) {
    const bool under_a = p.z() < 1e-6 && p.x() > 1.0 + 1e-3 && p.x() < 2.0 - 1e-3 && p.y() > -1.5 + 1e-3 && p.y() < -0.5 - 1e-3;
    const bool under_b = p.z() < 1e-6 && p.x() > -2.2 + 1e-3 && p.x() < -1.6 - 1e-3 && p.y() > 0.8 + 1e-3 && p.y() < 1.6 - 1e-3;
    CHECK_FALSE(under_a);
    CHECK_FALSE(under_b);
  }

  SECTION("a lower box leaves the ceiling out, and box B's top, which no camera below 1.7 m sees") {
    const Eigen::AlignedBox3d low(Vec3d(-3, -2, 0), Vec3d(3, 2, 2.0));
    const ObservableSurface o2(world, low, Vec3d(0, 0, 1.2), fastConfig());
    for (const Vec3d& p : o2.samples()) CHECK(p.z() <= 2.0);
    CHECK(o2.stats().observable_area_m2 ==
          Approx(floor + 2 * (6 + 4) * 2.0 + box_a + box_b - 0.48).epsilon(kAreaTolerance));
  }
  SECTION("a start that is not clear is refused") {
    CHECK_THROWS_AS(ObservableSurface(world, box, Vec3d(1.1, -1.0, 0.5), fastConfig()), std::invalid_argument);
  }
}

TEST_CASE("A closed room next door is not observable", "[sim][coverage]") {
  TriangleMesh m;
  test::addBox(m, Vec3d(0, 0, 0), Vec3d(4, 4, 2.5));
  test::addBox(m, Vec3d(4.2, 0, 0), Vec3d(8, 4, 2.5));  // sealed
  const World world(m);
  const Eigen::AlignedBox3d box(Vec3d(0, 0, 0), Vec3d(8, 4, 2.5));
  const ObservableSurface obs(world, box, Vec3d(2, 2, 1.2), fastConfig());
  const double first_room = 2 * 16.0 + 4 * 4.0 * 2.5;
  CHECK(obs.stats().observable_area_m2 == Approx(first_room).epsilon(kAreaTolerance));
  for (const Vec3d& p : obs.samples()) CHECK(p.x() <= 4.0 + 1e-6);
}

TEST_CASE("Coverage counts observable samples with a known voxel within one voxel", "[sim][coverage]") {
  const World world(test::roomWithBox());
  const Eigen::AlignedBox3d box(Vec3d(-3, -2, 0), Vec3d(3, 2, 2.5));
  const ObservableSurface obs(world, box, Vec3d(0, 0, 1.2), fastConfig());
  planner::DenseMap map(0.1, CoordBBox(Coord(-35, -25, -5), Coord(35, 25, 30)));
  CHECK(obs.coverage(map) == 0.0);  // nothing known
  map.fill(map.extent(), planner::Occupancy::Occupied);
  CHECK(obs.coverage(map) == 1.0);  // everything known (occupied counts as known)

  // Known only where x < 0 (voxel centres up to -0.1 m): a sample is known when a voxel centre
  // with x <= -0.1 lies within 0.1 m, so exactly the samples with x < 0 (brute force).
  map.fill(map.extent(), planner::Occupancy::Unknown);
  map.fill(CoordBBox(Coord(-35, -25, -5), Coord(-1, 25, 30)), planner::Occupancy::Free);
  const std::vector<bool> known = obs.known(map);
  std::size_t expected = 0, agree = 0;
  for (std::size_t i = 0; i < known.size(); ++i) {
    const Vec3d& p = obs.samples()[i];
    const planner::MapQuery& q = map;
    bool brute = false;
    for (int x = -35; x <= -1 && !brute; ++x)
      for (int dy = -1; dy <= 1 && !brute; ++dy)
        for (int dz = -1; dz <= 1 && !brute; ++dz) {
          const Coord c(x, q.worldToVoxel(p).y() + dy, q.worldToVoxel(p).z() + dz);
          brute = (q.voxelCenter(c) - p).norm() <= 0.1 + 1e-9;
        }
    expected += brute;
    agree += brute == known[i];
  }
  CHECK(agree == known.size());
  CHECK(obs.coverage(map) == Approx(double(expected) / double(known.size())));
  CHECK(obs.coverage(map) > 0.4);
  CHECK(obs.coverage(map) < 0.6);
}
