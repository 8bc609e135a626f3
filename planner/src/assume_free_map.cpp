#include "vdbmap/planner/assume_free_map.hpp"


namespace vdbmap::planner {

namespace {
class AssumeFreeReader : public MapReader {
 public:
  AssumeFreeReader(std::unique_ptr<MapReader> base, const std::vector<openvdb::CoordBBox>& boxes)
      : base_(std::move(base)), boxes_(boxes) {}

  Occupancy at(const openvdb::Coord& ijk) override {
    const Occupancy o = base_->at(ijk);
    if (o != Occupancy::Unknown) return o;
    for (const openvdb::CoordBBox& b : boxes_)
      if (b.isInside(ijk)) return Occupancy::Free;
    return o;
  }

 private:
  std::unique_ptr<MapReader> base_;
  const std::vector<openvdb::CoordBBox>& boxes_;
};
}  // namespace

AssumeFreeMap::AssumeFreeMap(const MapQuery& base, std::vector<Eigen::AlignedBox3d> free_boxes_W) : base_(&base) {
  for (const Eigen::AlignedBox3d& b : free_boxes_W) {
    const openvdb::CoordBBox box = base.voxelsIn(b);
    if (!box.empty()) boxes_.push_back(box);
  }
}

openvdb::CoordBBox AssumeFreeMap::knownBounds() const {
  openvdb::CoordBBox bounds = base_->knownBounds();
  for (const openvdb::CoordBBox& b : boxes_) bounds.expand(b);
  return bounds;
}

std::unique_ptr<MapReader> AssumeFreeMap::reader() const {
  return std::make_unique<AssumeFreeReader>(base_->reader(), boxes_);
}

Eigen::AlignedBox3d boxAround(const Vec3d& centre_W, const Vec3d& half_size_m) {
  return Eigen::AlignedBox3d(centre_W - half_size_m, centre_W + half_size_m);
}

}  // namespace vdbmap::planner
