#include "vdbmap/planner/tsdf_map_query.hpp"

#include "vdbmap/tsdf_volume.hpp"

namespace vdbmap::planner {

namespace {
/// Decodes W and WD exactly as TsdfVolume::sample() does (same float rounding of the tsdf), so the
/// planner and the map never disagree on a voxel.
class TsdfReader : public MapReader {
 public:
  TsdfReader(openvdb::Int64Grid::ConstPtr w, openvdb::Int64Grid::ConstPtr wd, const TsdfConfig& c)
      : w_grid_(std::move(w)),
        wd_grid_(std::move(wd)),
        w_acc_(w_grid_->getConstAccessor()),
        wd_acc_(wd_grid_->getConstAccessor()),
        min_w_(c.min_weight * double(kWeightScale)),
        truncation_m_(c.truncation_m()),
        occupied_below_m_(c.occupancy_threshold_vox * c.voxel_size_m) {}

  Occupancy at(const openvdb::Coord& ijk) override {
    const std::int64_t w = w_acc_.getValue(ijk);
    if (w <= 0 || double(w) <= min_w_) return Occupancy::Unknown;
    const std::int64_t wd = wd_acc_.getValue(ijk);
    const float tsdf_m = float(double(wd) / double(w) / double(kSdfScale) * truncation_m_);
    return tsdf_m < occupied_below_m_ ? Occupancy::Occupied : Occupancy::Free;
  }

 private:
  openvdb::Int64Grid::ConstPtr w_grid_;
  openvdb::Int64Grid::ConstPtr wd_grid_;
  openvdb::Int64Grid::ConstAccessor w_acc_;
  openvdb::Int64Grid::ConstAccessor wd_acc_;
  double min_w_;
  double truncation_m_;
  double occupied_below_m_;
};
}  // namespace

TsdfMapQuery::TsdfMapQuery(const TsdfVolume& volume) : volume_(&volume) {}

double TsdfMapQuery::voxelSize() const { return volume_->config().voxel_size_m; }

openvdb::CoordBBox TsdfMapQuery::knownBounds() const { return volume_->activeBoundingBox(); }

std::unique_ptr<MapReader> TsdfMapQuery::reader() const {
  return std::make_unique<TsdfReader>(volume_->weightSumGrid(), volume_->weightedSdfSumGrid(), volume_->config());
}

}  // namespace vdbmap::planner
