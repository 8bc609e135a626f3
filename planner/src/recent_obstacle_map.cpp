#include "vdbmap/planner/recent_obstacle_map.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace vdbmap::planner {

namespace {
class RecentObstacleReader : public MapReader {
 public:
  RecentObstacleReader(std::unique_ptr<MapReader> base, const RecentObstacleMap& map)
      : base_(std::move(base)), map_(map) {}

  Occupancy at(const openvdb::Coord& ijk) override {
    if (map_.isRecentSurface(ijk)) return Occupancy::Occupied;
    const Occupancy o = withSeenFree(ijk);
    if (o != Occupancy::Free) return o;
    for (int k = 1; k <= map_.verticalMarginVoxels(); ++k)
      if (withSeenFree(ijk.offsetBy(0, 0, k)) == Occupancy::Occupied ||
          withSeenFree(ijk.offsetBy(0, 0, -k)) == Occupancy::Occupied)
        return Occupancy::Occupied;
    return o;
  }

  void readBox(const openvdb::CoordBBox& box, Occupancy* out) override {
    const int m = map_.verticalMarginVoxels();
    const openvdb::Coord dim = box.dim();
    if (m == 0) {
      readWithSeenFree(box, out);
    } else {
      // The box read m voxels taller at both ends; each column of the box then reads occupied
      // where a free voxel has an obstacle within m voxels (a running count over 2m + 1 voxels).
      const openvdb::CoordBBox tall(box.min().offsetBy(0, 0, -m), box.max().offsetBy(0, 0, m));
      const openvdb::Coord tall_dim = tall.dim();
      tall_.resize(std::size_t(tall.volume()));
      readWithSeenFree(tall, tall_.data());
      for (int x = box.min().x(); x <= box.max().x(); ++x)
        for (int y = box.min().y(); y <= box.max().y(); ++y) {
          const Occupancy* column = &tall_[boxIndex(tall.min(), tall_dim, openvdb::Coord(x, y, tall.min().z()))];
          Occupancy* o = &out[boxIndex(box.min(), dim, openvdb::Coord(x, y, box.min().z()))];
          int obstacles = 0;  // in column[z, z + 2m] for box voxel z
          for (int z = 0; z < 2 * m; ++z) obstacles += column[z] == Occupancy::Occupied;
          for (int z = 0; z < dim.z(); ++z) {
            obstacles += column[z + 2 * m] == Occupancy::Occupied;
            const Occupancy here = column[z + m];
            o[z] = here == Occupancy::Free && obstacles > 0 ? Occupancy::Occupied : here;
            obstacles -= column[z] == Occupancy::Occupied;
          }
        }
    }
    openvdb::CoordBBox overlap = box;
    overlap.intersect(map_.surfaceBounds());
    if (overlap.empty()) return;
    for (int x = overlap.min().x(); x <= overlap.max().x(); ++x)
      for (int y = overlap.min().y(); y <= overlap.max().y(); ++y)
        for (int z = overlap.min().z(); z <= overlap.max().z(); ++z) {
          const openvdb::Coord c(x, y, z);
          if (map_.isRecentSurface(c)) out[boxIndex(box.min(), dim, c)] = Occupancy::Occupied;
        }
  }

 private:
  /// The base map's state with the seen free space read free (no recent surfaces, no margin).
  Occupancy withSeenFree(const openvdb::Coord& ijk) {
    const Occupancy base = base_->at(ijk);
    return base != Occupancy::Free && map_.isSeenFree(ijk) ? Occupancy::Free : base;
  }

  void readWithSeenFree(const openvdb::CoordBBox& box, Occupancy* out) {
    base_->readBox(box, out);
    openvdb::CoordBBox seen = box;
    seen.intersect(map_.seenFreeBounds());
    // An empty box must not be iterated: OpenVDB's box iterator tests only its first axis, so it
    // would visit voxels outside the box (and write outside `out`).
    if (seen.empty()) return;
    const openvdb::Coord dim = box.dim();
    for (auto it = seen.begin(); it; ++it) {
      Occupancy& o = out[boxIndex(box.min(), dim, *it)];
      if (o != Occupancy::Free && map_.isSeenFree(*it)) o = Occupancy::Free;
    }
  }

  std::unique_ptr<MapReader> base_;
  const RecentObstacleMap& map_;
  std::vector<Occupancy> tall_;  ///< readBox's taller box (kept to reuse its allocation)
};

std::unique_ptr<const SurfaceIndex> indexOf(const SurfaceVoxels& surface) {
  auto index = std::make_unique<SurfaceIndex>();
  for (const auto& [c, n] : surface) index->insert(c);
  return index;
}

/// The voxels of `map`'s recent surface bounds within the cube of half-size radius_m around p_W
/// (empty when none: iterating an empty box would visit voxels outside it).
openvdb::CoordBBox surfaceBoxAround(const RecentObstacleMap& map, const Vec3d& p_W, double radius_m) {
  openvdb::CoordBBox box(map.worldToVoxel(p_W - Vec3d::Constant(radius_m)),
                         map.worldToVoxel(p_W + Vec3d::Constant(radius_m)));
  box.intersect(map.surfaceBounds());
  return box;
}

}  // namespace

RecentObstacleMap::RecentObstacleMap(const MapQuery& base, const SurfaceVoxels& surface, const RecentFrames* seen_free,
                                     int vertical_margin_voxels)
    : RecentObstacleMap(base, indexOf(surface), nullptr, seen_free, vertical_margin_voxels) {}

RecentObstacleMap::RecentObstacleMap(const MapQuery& base, const SurfaceIndex& surface, const RecentFrames* seen_free,
                                     int vertical_margin_voxels)
    : RecentObstacleMap(base, nullptr, &surface, seen_free, vertical_margin_voxels) {}

RecentObstacleMap::RecentObstacleMap(const MapQuery& base, std::unique_ptr<const SurfaceIndex> owned,
                                     const SurfaceIndex* surface, const RecentFrames* seen_free,
                                     int vertical_margin_voxels)
    : base_(&base),
      owned_surface_(std::move(owned)),
      surface_((owned_surface_ ? *owned_surface_ : *surface).view()),
      seen_free_(seen_free),
      vertical_margin_(vertical_margin_voxels) {
  if (vertical_margin_voxels < 0 || vertical_margin_voxels > 100)
    throw std::invalid_argument("RecentObstacleMap: vertical_margin_voxels must be in [0, 100], got " +
                                std::to_string(vertical_margin_voxels));
  if (seen_free_) {
    const Eigen::AlignedBox3d reach = seen_free_->reach_W();
    if (!reach.isEmpty()) {
      // The frames were integrated into the base map, so what they saw lies in its known bounds.
      free_bounds_ = voxelsIn(reach);
      free_bounds_.intersect(base.knownBounds());
      free_dim_ = free_bounds_.dim();
    }
  }
}

bool RecentObstacleMap::isSeenFree(const openvdb::Coord& ijk) const {
  if (!free_bounds_.isInside(ijk)) return false;
  std::call_once(free_cache_once_, [this] {  // allocated on first use
    const std::size_t volume = std::size_t(free_dim_.x()) * std::size_t(free_dim_.y()) * std::size_t(free_dim_.z());
    if (volume <= kMaxCachedVoxels) free_cache_ = std::make_unique<std::atomic<std::uint8_t>[]>(volume);  // zeros
  });
  if (!free_cache_) return seen_free_->seesFree(voxelCenter(ijk));
  std::atomic<std::uint8_t>& known = free_cache_[boxIndex(free_bounds_.min(), free_dim_, ijk)];
  std::uint8_t answer = known.load(std::memory_order_relaxed);
  if (answer == 0) {
    answer = seen_free_->seesFree(voxelCenter(ijk)) ? 1 : 2;
    known.store(answer, std::memory_order_relaxed);
  }
  return answer == 1;
}

bool RecentObstacleMap::nearSurface(const Vec3d& p_W, double radius_m) const {
  const openvdb::CoordBBox box = surfaceBoxAround(*this, p_W, radius_m);
  if (box.empty()) return false;
  for (auto it = box.begin(); it; ++it)
    if (isRecentSurface(*it) && (voxelCenter(*it) - p_W).norm() <= radius_m) return true;
  return false;
}

double RecentObstacleMap::surfaceDistance(const Vec3d& p_W, double max_m) const {
  const openvdb::CoordBBox box = surfaceBoxAround(*this, p_W, max_m);
  double nearest = max_m;
  if (box.empty()) return nearest;
  for (auto it = box.begin(); it; ++it)
    if (isRecentSurface(*it)) nearest = std::min(nearest, (voxelCenter(*it) - p_W).norm());
  return nearest;
}

openvdb::CoordBBox RecentObstacleMap::knownBounds() const {
  openvdb::CoordBBox bounds = base_->knownBounds();
  if (!surface_.bounds.empty()) bounds.expand(surface_.bounds);
  return bounds;
}

std::unique_ptr<MapReader> RecentObstacleMap::reader() const {
  return std::make_unique<RecentObstacleReader>(base_->reader(), *this);
}

}  // namespace vdbmap::planner
