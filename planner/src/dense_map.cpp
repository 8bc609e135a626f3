#include "vdbmap/planner/dense_map.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace vdbmap::planner {

namespace {
class DenseReader : public MapReader {
 public:
  explicit DenseReader(const DenseMap& map) : map_(map) {}
  Occupancy at(const openvdb::Coord& ijk) override { return map_.get(ijk); }

 private:
  const DenseMap& map_;
};
}  // namespace

DenseMap::DenseMap(double voxel_size_m, const openvdb::CoordBBox& extent)
    : voxel_size_m_(voxel_size_m), extent_(extent) {
  if (!(voxel_size_m > 0.0) || !std::isfinite(voxel_size_m))
    throw std::invalid_argument("DenseMap: voxel_size_m = " + std::to_string(voxel_size_m) + " must be > 0");
  if (extent.empty()) throw std::invalid_argument("DenseMap: extent must not be empty");
  cells_.assign(extent.volume(), Occupancy::Unknown);
}

std::unique_ptr<MapReader> DenseMap::reader() const { return std::make_unique<DenseReader>(*this); }

std::size_t DenseMap::index(const openvdb::Coord& ijk) const { return boxIndex(extent_.min(), extent_.dim(), ijk); }

Occupancy DenseMap::get(const openvdb::Coord& ijk) const {
  return extent_.isInside(ijk) ? cells_[index(ijk)] : Occupancy::Unknown;
}

void DenseMap::set(const openvdb::Coord& ijk, Occupancy state) {
  if (!extent_.isInside(ijk))
    throw std::out_of_range("DenseMap::set: voxel (" + std::to_string(ijk.x()) + ", " + std::to_string(ijk.y()) +
                            ", " + std::to_string(ijk.z()) + ") is outside the map's extent");
  cells_[index(ijk)] = state;
  if (state != Occupancy::Unknown) known_.expand(ijk);
}

void DenseMap::fill(const openvdb::CoordBBox& box, Occupancy state) {
  openvdb::CoordBBox b = box;
  b.intersect(extent_);
  if (b.empty()) return;
  for (auto it = b.begin(); it; ++it) cells_[index(*it)] = state;
  if (state != Occupancy::Unknown) known_.expand(b);
}

void DenseMap::fillWorld(const Eigen::AlignedBox3d& box_W, Occupancy state) { fill(voxelsIn(box_W), state); }

}  // namespace vdbmap::planner
