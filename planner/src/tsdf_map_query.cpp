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
    if (!known(w)) return Occupancy::Unknown;
    return decode(w, wd_acc_.getValue(ijk));
  }

  /// Leaf by leaf: one tree descent per 8^3 block instead of one per voxel.
  void readBox(const openvdb::CoordBBox& box, Occupancy* out) override {
    using LeafT = openvdb::Int64Tree::LeafNodeType;
    const openvdb::Coord dim = box.dim();
    auto index = [&](int x, int y, int z) {
      return (std::size_t(x - box.min().x()) * std::size_t(dim.y()) + std::size_t(y - box.min().y())) *
                 std::size_t(dim.z()) +
             std::size_t(z - box.min().z());
    };
    const openvdb::Coord first = box.min() & ~(LeafT::DIM - 1);
    for (int lx = first.x(); lx <= box.max().x(); lx += LeafT::DIM)
      for (int ly = first.y(); ly <= box.max().y(); ly += LeafT::DIM)
        for (int lz = first.z(); lz <= box.max().z(); lz += LeafT::DIM) {
          const openvdb::Coord origin(lx, ly, lz);
          openvdb::CoordBBox part = openvdb::CoordBBox::createCube(origin, LeafT::DIM);
          part.intersect(box);
          // Without a leaf the region holds one tile value (usually the background 0: unknown).
          const LeafT* w_leaf = w_acc_.probeConstLeaf(origin);
          const LeafT* wd_leaf = wd_acc_.probeConstLeaf(origin);
          const std::int64_t w_tile = w_leaf ? 0 : w_acc_.getValue(origin);
          const std::int64_t wd_tile = wd_leaf ? 0 : wd_acc_.getValue(origin);
          for (int x = part.min().x(); x <= part.max().x(); ++x)
            for (int y = part.min().y(); y <= part.max().y(); ++y)
              for (int z = part.min().z(); z <= part.max().z(); ++z) {
                const openvdb::Coord c(x, y, z);
                const std::int64_t w = w_leaf ? w_leaf->getValue(c) : w_tile;
                out[index(x, y, z)] =
                    known(w) ? decode(w, wd_leaf ? wd_leaf->getValue(c) : wd_tile) : Occupancy::Unknown;
              }
        }
  }

 private:
  bool known(std::int64_t w) const { return w > 0 && double(w) > min_w_; }
  Occupancy decode(std::int64_t w, std::int64_t wd) const {
    const float tsdf_m = float(double(wd) / double(w) / double(kSdfScale) * truncation_m_);
    return tsdf_m < occupied_below_m_ ? Occupancy::Occupied : Occupancy::Free;
  }

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
