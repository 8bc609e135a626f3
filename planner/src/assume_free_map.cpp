#include "vdbmap/planner/assume_free_map.hpp"


namespace vdbmap::planner {

namespace {
class AssumeFreeReader : public MapReader {
 public:
  AssumeFreeReader(std::unique_ptr<MapReader> base, const std::vector<openvdb::CoordBBox>& boxes, bool occupied_too)
      : base_(std::move(base)), boxes_(boxes), occupied_too_(occupied_too) {}

  Occupancy at(const openvdb::Coord& ijk) override {
    const Occupancy o = base_->at(ijk);
    if (!overridden(o)) return o;
    for (const openvdb::CoordBBox& b : boxes_)
      if (b.isInside(ijk)) return Occupancy::Free;
    return o;
  }

  void readBox(const openvdb::CoordBBox& box, Occupancy* out) override {
    base_->readBox(box, out);
    const openvdb::Coord dim = box.dim();
    for (const openvdb::CoordBBox& b : boxes_) {
      openvdb::CoordBBox overlap = b;
      overlap.intersect(box);
      if (overlap.empty()) continue;
      for (int x = overlap.min().x(); x <= overlap.max().x(); ++x)
        for (int y = overlap.min().y(); y <= overlap.max().y(); ++y)
          for (int z = overlap.min().z(); z <= overlap.max().z(); ++z) {
            Occupancy& o = out[boxIndex(box.min(), dim, openvdb::Coord(x, y, z))];
            if (overridden(o)) o = Occupancy::Free;
          }
    }
  }

 private:
  bool overridden(Occupancy o) const { return o == Occupancy::Unknown || (occupied_too_ && o == Occupancy::Occupied); }

  std::unique_ptr<MapReader> base_;
  const std::vector<openvdb::CoordBBox>& boxes_;
  bool occupied_too_;
};
}  // namespace

AssumeFreeMap::AssumeFreeMap(const MapQuery& base, std::vector<Eigen::AlignedBox3d> free_boxes_W, bool occupied_too)
    : base_(&base), occupied_too_(occupied_too) {
  for (const Eigen::AlignedBox3d& b : free_boxes_W) {
    const openvdb::CoordBBox box = base.voxelsIn(b);
    if (!box.empty()) boxes_.push_back(box);
  }
  if (&base.sightMap() != &base)
    sight_ = std::make_shared<const AssumeFreeMap>(base.sightMap(), std::move(free_boxes_W), occupied_too);
}

const MapQuery& AssumeFreeMap::sightMap() const { return sight_ ? *sight_ : *this; }

openvdb::CoordBBox AssumeFreeMap::knownBounds() const {
  openvdb::CoordBBox bounds = base_->knownBounds();
  for (const openvdb::CoordBBox& b : boxes_) bounds.expand(b);
  return bounds;
}

std::unique_ptr<MapReader> AssumeFreeMap::reader() const {
  return std::make_unique<AssumeFreeReader>(base_->reader(), boxes_, occupied_too_);
}

Eigen::AlignedBox3d boxAround(const Vec3d& centre_W, const Vec3d& half_size_m) {
  return Eigen::AlignedBox3d(centre_W - half_size_m, centre_W + half_size_m);
}

}  // namespace vdbmap::planner
