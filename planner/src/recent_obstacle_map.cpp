#include "vdbmap/planner/recent_obstacle_map.hpp"

namespace vdbmap::planner {

namespace {
class RecentObstacleReader : public MapReader {
 public:
  RecentObstacleReader(std::unique_ptr<MapReader> base, const SurfaceVoxels& surface, const openvdb::CoordBBox& bounds)
      : base_(std::move(base)), surface_(surface), bounds_(bounds) {}

  Occupancy at(const openvdb::Coord& ijk) override {
    if (bounds_.isInside(ijk) && surface_.count(ijk) > 0) return Occupancy::Occupied;
    return base_->at(ijk);
  }

  void readBox(const openvdb::CoordBBox& box, Occupancy* out) override {
    base_->readBox(box, out);
    openvdb::CoordBBox overlap = box;
    overlap.intersect(bounds_);
    if (overlap.empty()) return;
    const openvdb::Coord dim = box.dim();
    const auto set = [&](const openvdb::Coord& c) {
      out[(std::size_t(c.x() - box.min().x()) * std::size_t(dim.y()) + std::size_t(c.y() - box.min().y())) *
              std::size_t(dim.z()) +
          std::size_t(c.z() - box.min().z())] = Occupancy::Occupied;
    };
    if (overlap.volume() <= surface_.size()) {  // look up each voxel of the overlap, or walk the set
      for (auto it = overlap.begin(); it; ++it)
        if (surface_.count(*it) > 0) set(*it);
    } else {
      for (const auto& [c, n] : surface_)
        if (overlap.isInside(c)) set(c);
    }
  }

 private:
  std::unique_ptr<MapReader> base_;
  const SurfaceVoxels& surface_;
  openvdb::CoordBBox bounds_;
};
}  // namespace

RecentObstacleMap::RecentObstacleMap(const MapQuery& base, const SurfaceVoxels& surface)
    : base_(&base), surface_(&surface) {
  for (const auto& [c, n] : surface) surface_bounds_.expand(c);
}

openvdb::CoordBBox RecentObstacleMap::knownBounds() const {
  openvdb::CoordBBox bounds = base_->knownBounds();
  if (!surface_bounds_.empty()) bounds.expand(surface_bounds_);
  return bounds;
}

std::unique_ptr<MapReader> RecentObstacleMap::reader() const {
  return std::make_unique<RecentObstacleReader>(base_->reader(), *surface_, surface_bounds_);
}

}  // namespace vdbmap::planner
