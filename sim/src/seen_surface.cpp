#include "vdbmap/sim/seen_surface.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace vdbmap::sim {

namespace {
class SeenReader : public planner::MapReader {
 public:
  explicit SeenReader(const openvdb::BoolGrid& grid) : accessor_(grid.getConstAccessor()) {}
  planner::Occupancy at(const openvdb::Coord& ijk) override {
    return accessor_.isValueOn(ijk) ? planner::Occupancy::Occupied : planner::Occupancy::Unknown;
  }

 private:
  openvdb::BoolGrid::ConstAccessor accessor_;
};
}  // namespace

SeenSurface::SeenSurface(double voxel_size_m) : voxel_size_m_(voxel_size_m), grid_(openvdb::BoolGrid::create(false)) {
  if (!(std::isfinite(voxel_size_m) && voxel_size_m > 0.0))
    throw std::invalid_argument("SeenSurface: voxel_size_m must be finite and > 0, got " +
                                std::to_string(voxel_size_m));
}

void SeenSurface::addFrame(const DepthImage& depth, const CameraIntrinsics& K, const Pose3d& T_W_S,
                           double max_range_m) {
  checkDepthImageSize(depth, K, "SeenSurface::addFrame");
  if (!(std::isfinite(max_range_m) && max_range_m > 0.0))
    throw std::invalid_argument("SeenSurface::addFrame: max_range_m must be finite and > 0");
  // A pixel spans max_range_m / f metres at the far end of the range.
  const double f = std::min(std::abs(K.fx), std::abs(K.fy));
  const int stride = std::max(1, int(std::floor(0.5 * voxel_size_m_ * f / max_range_m)));
  const double inv_fx = 1.0 / K.fx, inv_fy = 1.0 / K.fy;
  openvdb::BoolGrid::Accessor acc = grid_->getAccessor();
  for (int v = 0; v < depth.height; v += stride)
    for (int u = 0; u < depth.width; u += stride) {
      const float z = depth.at(u, v);
      if (!(z > 0.0f && double(z) <= max_range_m)) continue;  // NaN fails too
      // The point the mapper integrates for this pixel (camera.hpp).
      const Vec3d p_S = backProjectPixel(u, v, z, K, inv_fx, inv_fy).cast<double>();
      acc.setValueOn(planner::voxelOf(T_W_S * p_S, voxel_size_m_), true);
    }
}

openvdb::CoordBBox SeenSurface::knownBounds() const { return grid_->evalActiveVoxelBoundingBox(); }

std::unique_ptr<planner::MapReader> SeenSurface::reader() const { return std::make_unique<SeenReader>(*grid_); }

}  // namespace vdbmap::sim
