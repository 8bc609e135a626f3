// Synthetic maps, brute-force references and checks shared by the planner tests.
#pragma once

#include "vdbmap/planner/dense_map.hpp"
#include "vdbmap/planner/path_planner.hpp"
#include "vdbmap/planner/vehicle_state.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <limits>
#include <optional>
#include <vector>

namespace vdbmap::planner::test {

/// CPU time of the calling thread in seconds: unlike the wall clock it does not run on while a
/// loaded machine leaves the thread waiting, yet it runs on as long as the thread keeps working,
/// so a search that ignores its deadline still shows.
inline double threadCpuSeconds() {
  timespec now{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec);
}

/// Path searches bounded by a count of RRTConnect iterations, their time limit far above what they
/// take, so that a search ends the same on a loaded machine as on an idle one.
inline PathConfig countedPaths(std::uint64_t max_iterations = 3000) {
  PathConfig p;
  p.time_limit_s = 10.0;
  p.max_iterations = max_iterations;
  return p;
}

/// The vehicle at rest at p with this yaw.
inline VehicleState at(const Vec3d& p, double yaw = 0.0) {
  VehicleState s;
  s.position_W = p;
  s.yaw_rad = yaw;
  return s;
}

/// A room of `size_m` (x, y, z) at 0.1 m voxels: occupied walls, floor and ceiling one voxel
/// thick, free inside, unknown outside. Voxel coordinates of the inside: [1, n-2] per axis.
inline DenseMap makeRoom(const Eigen::Vector3i& size_vox, double voxel_m = 0.1) {
  const openvdb::CoordBBox all(openvdb::Coord(-2), openvdb::Coord(size_vox.x() + 1, size_vox.y() + 1, size_vox.z() + 1));
  DenseMap map(voxel_m, all);
  map.fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(size_vox.x() - 1, size_vox.y() - 1, size_vox.z() - 1)),
           Occupancy::Occupied);
  map.fill(openvdb::CoordBBox(openvdb::Coord(1), openvdb::Coord(size_vox.x() - 2, size_vox.y() - 2, size_vox.z() - 2)),
           Occupancy::Free);
  return map;
}

/// A reader's readBox over `box` reads, voxel by voxel, what its at() reads, and writes nothing
/// outside the box's volume (guard cells on either side of the buffer stay as they were).
inline void requireReadBoxMatchesAt(MapReader& reader, const openvdb::CoordBBox& box) {
  const std::size_t guard = 4096;
  const Occupancy sentinel = static_cast<Occupancy>(0x5a);
  std::vector<Occupancy> out(box.volume() + 2 * guard, sentinel);
  reader.readBox(box, out.data() + guard);
  for (std::size_t g = 0; g < guard; ++g) {
    REQUIRE(out[g] == sentinel);
    REQUIRE(out[out.size() - 1 - g] == sentinel);
  }
  std::size_t i = guard;
  for (int x = box.min().x(); x <= box.max().x(); ++x)
    for (int y = box.min().y(); y <= box.max().y(); ++y)
      for (int z = box.min().z(); z <= box.max().z(); ++z) REQUIRE(out[i++] == reader.at(openvdb::Coord(x, y, z)));
}

/// Distance from p to the segment a-b.
inline double pointSegmentDistance(const Vec3d& p, const Vec3d& a, const Vec3d& b) {
  const Vec3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

/// Brute force: every voxel of `map` whose centre is within r of p is free (scans a box).
inline bool bruteClear(const DenseMap& map, const Vec3d& p, double r) {
  if (map.get(map.worldToVoxel(p)) != Occupancy::Free) return false;
  const double s = map.voxelSize();
  const openvdb::Coord lo = map.worldToVoxel(p - Vec3d::Constant(r + s)), hi = map.worldToVoxel(p + Vec3d::Constant(r + s));
  for (int x = lo.x(); x <= hi.x(); ++x)
    for (int y = lo.y(); y <= hi.y(); ++y)
      for (int z = lo.z(); z <= hi.z(); ++z) {
        const openvdb::Coord c(x, y, z);
        if ((map.voxelCenter(c) - p).norm() <= r && map.get(c) != Occupancy::Free) return false;
      }
  return true;
}

/// Brute force: every voxel whose centre is within r of the segment a-b is free.
inline bool bruteSegmentClear(const DenseMap& map, const Vec3d& a, const Vec3d& b, double r) {
  const double s = map.voxelSize();
  const Vec3d lo = a.cwiseMin(b) - Vec3d::Constant(r + s), hi = a.cwiseMax(b) + Vec3d::Constant(r + s);
  const openvdb::Coord l = map.worldToVoxel(lo), h = map.worldToVoxel(hi);
  for (int x = l.x(); x <= h.x(); ++x)
    for (int y = l.y(); y <= h.y(); ++y)
      for (int z = l.z(); z <= h.z(); ++z) {
        const openvdb::Coord c(x, y, z);
        if (pointSegmentDistance(map.voxelCenter(c), a, b) <= r && map.get(c) != Occupancy::Free) return false;
      }
  return true;
}

/// Brute force: of the voxels the segment a-b intersects (slab test against each voxel's cube),
/// the one not known-free that the segment enters first (none when all are free).
inline std::optional<openvdb::Coord> bruteFirstNotFree(const DenseMap& map, const Vec3d& a, const Vec3d& b) {
  const double s = map.voxelSize();
  std::optional<openvdb::Coord> first;
  double first_t = std::numeric_limits<double>::infinity();
  const openvdb::Coord l = map.worldToVoxel(a.cwiseMin(b)), h = map.worldToVoxel(a.cwiseMax(b));
  const Vec3d d = b - a;
  for (auto it = openvdb::CoordBBox(l, h).begin(); it; ++it) {
    if (map.get(*it) == Occupancy::Free) continue;
    const Vec3d lo = map.voxelCenter(*it) - Vec3d::Constant(0.5 * s), hi = lo + Vec3d::Constant(s);
    double t0 = 0.0, t1 = 1.0;
    for (int k = 0; k < 3; ++k) {
      if (std::abs(d[k]) < 1e-15) {
        if (!(a[k] >= lo[k] && a[k] < hi[k])) t0 = 2.0;
        continue;
      }
      double ta = (lo[k] - a[k]) / d[k], tb = (hi[k] - a[k]) / d[k];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
    }
    if (t0 <= t1 && t0 < first_t) first_t = t0, first = *it;
  }
  return first;
}

/// Brute force: every voxel the segment a-b intersects (slab test against each voxel's cube) is free.
inline bool bruteVisible(const DenseMap& map, const Vec3d& a, const Vec3d& b) {
  return !bruteFirstNotFree(map, a, b).has_value();
}

/// A 10 x 6 x 3 m room (makeRoom) split by a one-voxel wall at x = 5 m, with a door (y 2.5-3.5 m,
/// z up to 2 m) unless `door` is false.
inline DenseMap wallRoom(bool door = true) {
  DenseMap map = makeRoom(Eigen::Vector3i(100, 60, 30));
  map.fill(openvdb::CoordBBox(openvdb::Coord(50, 1, 1), openvdb::Coord(50, 58, 28)), Occupancy::Occupied);
  if (door) map.fill(openvdb::CoordBBox(openvdb::Coord(50, 25, 1), openvdb::Coord(50, 35, 20)), Occupancy::Free);
  return map;
}

/// An 8 x 6 x 3 m room whose half x < 4 m is known (walls occupied, inside free); the rest is
/// unknown, so the plane x = 3.9 m is one big frontier. A pillar stands in the known half.
inline DenseMap halfKnownRoom() {
  using openvdb::Coord;
  using openvdb::CoordBBox;
  DenseMap map(0.1, CoordBBox(Coord(-2), Coord(82, 62, 32)));
  map.fill(CoordBBox(Coord(0), Coord(39, 59, 29)), Occupancy::Occupied);
  map.fill(CoordBBox(Coord(1), Coord(39, 58, 28)), Occupancy::Free);
  map.fill(CoordBBox(Coord(20, 25, 1), Coord(23, 28, 28)), Occupancy::Occupied);  // pillar
  return map;
}

/// halfKnownRoom with a slot of unknown space 0.6 m high and 5.6 m long (x = 4.0 m, y 0.2-5.7 m,
/// z 1.1-1.6 m) beside its known half, the rest beyond x = 4 m occupied, behind a plate at
/// x = 3.7 m with a 0.5 m gap: as in goods on shelving, every viewpoint sees only the few slot
/// voxels the gap shows. Its frontier is the free voxels at x = 3.9 m beside the slot.
inline DenseMap slotBehindPlate() {
  using openvdb::Coord;
  using openvdb::CoordBBox;
  DenseMap map = halfKnownRoom();
  map.fill(CoordBBox(Coord(40, 0, 0), Coord(82, 62, 32)), Occupancy::Occupied);
  map.fill(CoordBBox(Coord(40, 2, 11), Coord(40, 57, 16)), Occupancy::Unknown);
  map.fill(CoordBBox(Coord(37, 1, 1), Coord(37, 58, 28)), Occupancy::Occupied);
  map.fill(CoordBBox(Coord(37, 27, 11), Coord(37, 31, 16)), Occupancy::Free);
  return map;
}

/// Every point of the path, every 5 mm, has only free voxel centres within r (brute force).
inline bool denselyClear(const DenseMap& map, const std::vector<Vec3d>& path, double r) {
  for (std::size_t i = 1; i < path.size(); ++i) {
    const double len = (path[i] - path[i - 1]).norm();
    const int n = std::max(1, int(std::ceil(len / 0.005)));
    for (int k = 0; k <= n; ++k)
      if (!bruteClear(map, path[i - 1] + (path[i] - path[i - 1]) * (double(k) / n), r)) return false;
  }
  return true;
}

}  // namespace vdbmap::planner::test
