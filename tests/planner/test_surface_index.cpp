// SurfaceIndex: a set of voxels as bits of a growing box, against a reference set; its bounds
// exact after every change.
#include "vdbmap/planner/surface_index.hpp"

#include <catch2/catch.hpp>

#include <random>
#include <set>
#include <tuple>

using namespace vdbmap::planner;
using openvdb::Coord;
using openvdb::CoordBBox;

namespace {
using Reference = std::set<std::tuple<int, int, int>>;

CoordBBox boundsOf(const Reference& set) {
  CoordBBox box;  // empty
  for (const auto& [x, y, z] : set) box.expand(Coord(x, y, z));
  return box;
}

/// Every voxel of `region` is in the index exactly when it is in the reference, and the bounds
/// and size are the reference's.
void requireSame(const SurfaceIndex& index, const Reference& set, const CoordBBox& region) {
  REQUIRE(index.size() == set.size());
  REQUIRE(index.bounds() == boundsOf(set));
  for (auto it = region.begin(); it; ++it)
    REQUIRE(index.contains(*it) == (set.count({(*it).x(), (*it).y(), (*it).z()}) > 0));
  for (const auto& [x, y, z] : set) REQUIRE(index.contains(Coord(x, y, z)));
}
}  // namespace

TEST_CASE("SurfaceIndex holds exactly the voxels inserted and not erased, with exact bounds", "[planner][safety]") {
  SurfaceIndex index;
  Reference set;
  CHECK(index.empty());
  CHECK(index.bounds().empty());
  CHECK_FALSE(index.contains(Coord(0)));
  std::mt19937 rng(3);
  // A set that wanders as the vehicle does: inserts around a moving centre, erases of old voxels,
  // so that the box grows on every side and the bounds move in as well as out.
  for (int step = 0; step < 80; ++step) {  // far enough that the box is fitted to the set again
    const Coord centre(3 * step - 40, -2 * step + 15, step % 9 - 4);
    std::uniform_int_distribution<int> near(-12, 12);
    for (int i = 0; i < 300; ++i) {
      const Coord c = centre.offsetBy(near(rng), near(rng), near(rng) / 3);
      index.insert(c);
      set.insert({c.x(), c.y(), c.z()});
    }
    // Erase about half of the set, the oldest region first (the lowest x), and some at random.
    std::vector<std::tuple<int, int, int>> erase;
    for (const auto& v : set)
      if (std::get<0>(v) < centre.x() - 20 || rng() % 4 == 0) erase.push_back(v);
    for (const auto& [x, y, z] : erase) {
      index.erase(Coord(x, y, z));
      set.erase({x, y, z});
    }
    index.erase(Coord(10000));  // not in the set: no effect
    index.insert(centre);       // twice: once
    index.insert(centre);
    set.insert({centre.x(), centre.y(), centre.z()});
    if (step % 8 == 0) requireSame(index, set, boundsOf(set).expandBy(3));
  }
  requireSame(index, set, boundsOf(set).expandBy(3));
  for (const auto& [x, y, z] : Reference(set)) {
    index.erase(Coord(x, y, z));
    set.erase({x, y, z});
  }
  CHECK(index.empty());
  CHECK(index.bounds().empty());
}

TEST_CASE("SurfaceIndex keeps voxels beyond its largest bit box", "[planner][safety]") {
  // Two voxels whose box exceeds kMaxVoxels: the second is held outside the bits.
  SurfaceIndex index;
  const Coord a(0), b(1200, 1200, 200), c(1, 2, 3);
  REQUIRE(double(b.x() + 1) * (b.y() + 1) * (b.z() + 1) > double(SurfaceIndex::kMaxVoxels));
  index.insert(a);
  index.insert(b);
  index.insert(c);
  CHECK(index.size() == 3);
  CHECK(index.contains(a));
  CHECK(index.contains(b));
  CHECK(index.contains(c));
  CHECK_FALSE(index.contains(Coord(1200, 1200, 199)));
  CHECK(index.bounds() == CoordBBox(a, b));
  index.erase(b);
  CHECK_FALSE(index.contains(b));
  CHECK(index.bounds() == CoordBBox(a, c));
  index.clear();
  CHECK(index.empty());
  CHECK_FALSE(index.contains(a));
}
