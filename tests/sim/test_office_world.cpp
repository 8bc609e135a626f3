// Generated offices: the same seed gives the same mesh, seeds differ, the size is kept, and every
// room is reachable from the corridor by a vehicle keeping its clearance (a flood fill through the
// world's exact distances), doors between rooms included.
#include "vdbmap/sim/office_world.hpp"
#include "vdbmap/sim/world.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <queue>

using namespace vdbmap;
using sim::OfficeWorld;
using sim::OfficeWorldConfig;

namespace {

/// Cells of a grid at height z_m reachable from `start` keeping `clearance_m` from every surface.
std::vector<Vec3d> reachable(const sim::World& world, const Eigen::AlignedBox3d& box, const Vec3d& start, double cell_m,
                             double clearance_m) {
  const int nx = int(std::floor(box.sizes().x() / cell_m)), ny = int(std::floor(box.sizes().y() / cell_m));
  const auto centre = [&](int i, int j) { return Vec3d(box.min().x() + (i + 0.5) * cell_m, box.min().y() + (j + 0.5) * cell_m, start.z()); };
  std::vector<char> seen(std::size_t(nx * ny), 0);
  std::queue<std::pair<int, int>> open;
  const int si = int((start.x() - box.min().x()) / cell_m), sj = int((start.y() - box.min().y()) / cell_m);
  open.push({si, sj});
  seen[std::size_t(sj * nx + si)] = 1;
  std::vector<Vec3d> out;
  while (!open.empty()) {
    const auto [i, j] = open.front();
    open.pop();
    out.push_back(centre(i, j));
    const int di[4] = {1, -1, 0, 0}, dj[4] = {0, 0, 1, -1};
    for (int k = 0; k < 4; ++k) {
      const int a = i + di[k], b = j + dj[k];
      if (a < 0 || b < 0 || a >= nx || b >= ny || seen[std::size_t(b * nx + a)]) continue;
      seen[std::size_t(b * nx + a)] = 1;
      if (world.isClear(centre(a, b), clearance_m)) open.push({a, b});
    }
  }
  return out;
}

}  // namespace

TEST_CASE("an office is the same for the same seed, different for another, and of the asked size", "[sim][office]") {
  OfficeWorldConfig c;
  c.size_x_m = 20.0;
  c.size_y_m = 14.0;
  c.seed = 4;
  const OfficeWorld a = sim::generateOffice(c), b = sim::generateOffice(c);
  CHECK(a.mesh.vertices == b.mesh.vertices);
  CHECK(a.mesh.triangles == b.mesh.triangles);
  c.seed = 5;
  const OfficeWorld other = sim::generateOffice(c);
  CHECK(other.mesh.vertices != a.mesh.vertices);
  const sim::World world(a.mesh);
  // The walls' outer faces and the floor and ceiling slabs bound it.
  CHECK(world.bounds().min().x() == Approx(-c.wall_thickness_m));
  CHECK(world.bounds().max().x() == Approx(c.size_x_m + c.wall_thickness_m));
  CHECK(world.bounds().max().y() == Approx(c.size_y_m + c.wall_thickness_m));
  CHECK(world.bounds().max().z() == Approx(c.height_m + 0.1));
  CHECK(a.rooms.size() >= 2 * std::size_t(std::floor(c.size_x_m / c.max_room_m)));
  CHECK(a.doors >= a.rooms.size());  // one to the corridor each, and some between rooms
  for (const Eigen::AlignedBox3d& room : a.rooms) {
    CHECK(room.sizes().x() >= c.min_room_m - c.wall_thickness_m - 1e-9);
    CHECK(room.sizes().y() >= c.min_room_m - 1e-9);
  }
}

TEST_CASE("every room of generated offices is reachable from the corridor with the vehicle's clearance",
          "[sim][office]") {
  for (std::uint64_t seed : {1, 2, 3}) {
    OfficeWorldConfig c;
    c.size_x_m = 24.0;
    c.size_y_m = 14.0;
    c.seed = seed;
    const OfficeWorld office = sim::generateOffice(c);
    const sim::World world(office.mesh);
    INFO("seed " << seed << ": " << office.rooms.size() << " rooms, " << office.doors << " doors, "
                 << office.pillars << " pillars, " << office.clutter << " desks and cabinets");
    CHECK(office.clutter > 0);
    const Vec3d start = office.corridor.center();
    const Eigen::AlignedBox3d floor(Vec3d(0, 0, 0), Vec3d(c.size_x_m, c.size_y_m, c.height_m));
    const double clearance = 0.35;  // the planner's 0.3 m viewpoint clearance, with margin
    REQUIRE(world.isClear(Vec3d(start.x(), start.y(), 1.0), clearance));
    const std::vector<Vec3d> cells = reachable(world, floor, Vec3d(start.x(), start.y(), 1.0), 0.1, clearance);
    for (std::size_t r = 0; r < office.rooms.size(); ++r) {
      const Eigen::AlignedBox3d& room = office.rooms[r];
      std::size_t inside = 0;
      for (const Vec3d& p : cells) inside += room.contains(p) ? 1 : 0;
      INFO("room " << r);
      CHECK(double(inside) * 0.01 > 0.3 * room.sizes().x() * room.sizes().y());  // most of its floor
    }
  }
}

TEST_CASE("an office config out of range is refused, naming the field", "[sim][office]") {
  OfficeWorldConfig c;
  c.size_y_m = 5.0;
  CHECK_THROWS_WITH(sim::generateOffice(c), Catch::Contains("size_y_m"));
  c = OfficeWorldConfig{};
  c.door_width_m = 0.2;
  CHECK_THROWS_WITH(sim::generateOffice(c), Catch::Contains("door_width_m"));
  c = OfficeWorldConfig{};
  c.max_room_m = 2.0;
  CHECK_THROWS_WITH(sim::generateOffice(c), Catch::Contains("max_room_m"));
}
