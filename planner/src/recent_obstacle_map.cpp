#include "vdbmap/planner/recent_obstacle_map.hpp"

namespace vdbmap::planner {

namespace {
class RecentObstacleReader : public MapReader {
 public:
  RecentObstacleReader(std::unique_ptr<MapReader> base, const RecentObstacleMap& map)
      : base_(std::move(base)), map_(map) {}

  Occupancy at(const openvdb::Coord& ijk) override {
    return map_.isRecentSurface(ijk) ? Occupancy::Occupied : base_->at(ijk);
  }

  void readBox(const openvdb::CoordBBox& box, Occupancy* out) override {
    base_->readBox(box, out);
    openvdb::CoordBBox overlap = box;
    overlap.intersect(map_.surfaceBounds());
    if (overlap.empty()) return;
    const openvdb::Coord dim = box.dim();
    for (int x = overlap.min().x(); x <= overlap.max().x(); ++x)
      for (int y = overlap.min().y(); y <= overlap.max().y(); ++y)
        for (int z = overlap.min().z(); z <= overlap.max().z(); ++z) {
          const openvdb::Coord c(x, y, z);
          if (map_.isRecentSurface(c)) out[boxIndex(box.min(), dim, c)] = Occupancy::Occupied;
        }
  }

 private:
  std::unique_ptr<MapReader> base_;
  const RecentObstacleMap& map_;
};
}  // namespace

RecentObstacleMap::RecentObstacleMap(const MapQuery& base, const SurfaceVoxels& surface)
    : base_(&base), surface_(&surface) {
  for (const auto& [c, n] : surface) bounds_.expand(c);
  if (bounds_.empty()) return;
  dim_ = bounds_.dim();
  const std::size_t volume = std::size_t(dim_.x()) * std::size_t(dim_.y()) * std::size_t(dim_.z());
  if (volume > kMaxDenseVoxels) return;
  bits_.assign((volume + 63) / 64, 0);
  for (const auto& [c, n] : surface) {
    const std::size_t i = boxIndex(bounds_.min(), dim_, c);
    bits_[i / 64] |= std::uint64_t(1) << (i % 64);
  }
}

bool RecentObstacleMap::nearSurface(const Vec3d& p_W, double radius_m) const {
  const openvdb::Coord lo = worldToVoxel(p_W - Vec3d::Constant(radius_m)),
                       hi = worldToVoxel(p_W + Vec3d::Constant(radius_m));
  openvdb::CoordBBox box(lo, hi);
  box.intersect(bounds_);
  for (auto it = box.begin(); it; ++it)
    if (isRecentSurface(*it) && (voxelCenter(*it) - p_W).norm() <= radius_m) return true;
  return false;
}

openvdb::CoordBBox RecentObstacleMap::knownBounds() const {
  openvdb::CoordBBox bounds = base_->knownBounds();
  if (!bounds_.empty()) bounds.expand(bounds_);
  return bounds;
}

std::unique_ptr<MapReader> RecentObstacleMap::reader() const {
  return std::make_unique<RecentObstacleReader>(base_->reader(), *this);
}

}  // namespace vdbmap::planner
