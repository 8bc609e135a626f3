#include "vdbmap/planner/tsdf_map_query.hpp"

#include "vdbmap/tsdf_volume.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace vdbmap::planner {

namespace {
/// Decodes W and WD through the map's own VoxelCodec, so that, without thin and hit obstacles, the
/// planner and the map never disagree on a voxel.
class TsdfReader : public MapReader {
 public:
  TsdfReader(openvdb::Int64Grid::ConstPtr w, openvdb::Int64Grid::ConstPtr wd, openvdb::Int64Grid::ConstPtr hits,
             const TsdfConfig& c, const TsdfMapQueryConfig& p)
      : w_grid_(std::move(w)),
        wd_grid_(std::move(wd)),
        hits_grid_(std::move(hits)),
        w_acc_(w_grid_->getConstAccessor()),
        wd_acc_(wd_grid_->getConstAccessor()),
        hits_acc_(hits_grid_->getConstAccessor()),
        codec_(c),
        thin_(p.thin_obstacles),
        thin_below_m_(float(p.thin_below_vox * c.voxel_size_m)),
        thin_margin_m_(float(p.thin_margin_vox * c.voxel_size_m)),
        hit_obstacles_(p.hit_obstacles),
        min_hits_(p.min_hits) {}

  Occupancy at(const openvdb::Coord& ijk) override {
    return classify(
        tsdfAt(ijk), [&] { return hits_acc_.getValue(ijk); }, [&](const openvdb::Coord& d) { return tsdfAt(ijk + d); });
  }

  /// Leaf by leaf: one tree descent per 8^3 block instead of one per voxel. With thin obstacles or
  /// hit obstacles the block is read one voxel wider, for the neighbours.
  void readBox(const openvdb::CoordBBox& box, Occupancy* out) override {
    const openvdb::CoordBBox wide = (thin_ || hit_obstacles_) ? box.expandBy(1) : box;
    tsdf_.resize(std::size_t(wide.volume()));
    readTsdf(wide, tsdf_.data());
    if (hit_obstacles_) {
      hits_.resize(std::size_t(box.volume()));
      readHits(box, hits_.data());
    }
    const openvdb::Coord dim = wide.dim();
    const std::ptrdiff_t sx = std::ptrdiff_t(dim.y()) * dim.z(), sy = dim.z();
    std::size_t i = 0;
    for (int x = box.min().x(); x <= box.max().x(); ++x)
      for (int y = box.min().y(); y <= box.max().y(); ++y)
        for (int z = box.min().z(); z <= box.max().z(); ++z, ++i) {
          const std::ptrdiff_t k =
              std::ptrdiff_t(x - wide.min().x()) * sx + std::ptrdiff_t(y - wide.min().y()) * sy + (z - wide.min().z());
          out[i] = classify(
              tsdf_[std::size_t(k)], [&] { return hits_[i]; },
              [&](const openvdb::Coord& d) { return tsdf_[std::size_t(k + d.x() * sx + d.y() * sy + d.z())]; });
        }
  }

 private:
  /// The voxel's tsdf in metres, NaN when unknown.
  float tsdfOf(std::int64_t w, std::int64_t wd) const { return codec_.tsdfOrNan(w, wd); }
  float tsdfAt(const openvdb::Coord& ijk) { return tsdfOf(w_acc_.getValue(ijk), wd_acc_.getValue(ijk)); }

  /// The map's rule (unknown, occupied below the threshold, free), plus tsdf valleys and, amid free
  /// voxels, voxels with hits as occupied. `tsdf_at(d)` gives the tsdf of the neighbour at offset d (NaN
  /// when unknown); `hits()` the voxel's hit count.
  template <typename Hits, typename Neighbour>
  Occupancy classify(float t, Hits&& hits, Neighbour&& tsdf_at) const {
    if (std::isnan(t)) return Occupancy::Unknown;
    if (codec_.occupied(t)) return Occupancy::Occupied;
    if (thin_ && t < thin_below_m_ && isValley(t, tsdf_at)) return Occupancy::Occupied;
    if (hit_obstacles_ && hits() >= min_hits_ && faceNeighboursAllFree(tsdf_at))
      return Occupancy::Occupied;
    return Occupancy::Free;
  }

  /// Whether all six face neighbours are known and free (by the map's own rule).
  template <typename Neighbour>
  bool faceNeighboursAllFree(Neighbour&& tsdf_at) const {
    for (int axis = 0; axis < 3; ++axis)
      for (int s = -1; s <= 1; s += 2) {
        openvdb::Coord d(0, 0, 0);
        d[axis] = s;
        const float t = tsdf_at(d);
        if (std::isnan(t) || codec_.occupied(t)) return false;  // unknown, or occupied
      }
    return true;
  }

  /// Lower by the margin than both neighbours along x, y or z (unknown neighbours are not higher).
  template <typename Neighbour>
  bool isValley(float t, Neighbour&& tsdf_at) const {
    const float need = t + thin_margin_m_;
    for (int axis = 0; axis < 3; ++axis) {
      openvdb::Coord d(0, 0, 0);
      d[axis] = 1;
      const float lo = tsdf_at(-d), hi = tsdf_at(d);
      if (lo >= need && hi >= need) return true;  // false for NaN
    }
    return false;
  }

  /// Calls part_fn(origin, part) for each piece of `box` inside one 8^3 leaf at `origin`.
  template <typename PartFn>
  static void forEachLeafPart(const openvdb::CoordBBox& box, PartFn&& part_fn) {
    constexpr int kDim = int(openvdb::Int64Tree::LeafNodeType::DIM);
    const openvdb::Coord first = box.min() & ~(kDim - 1);
    for (int lx = first.x(); lx <= box.max().x(); lx += kDim)
      for (int ly = first.y(); ly <= box.max().y(); ly += kDim)
        for (int lz = first.z(); lz <= box.max().z(); lz += kDim) {
          const openvdb::Coord origin(lx, ly, lz);
          openvdb::CoordBBox part = openvdb::CoordBBox::createCube(origin, kDim);
          part.intersect(box);
          part_fn(origin, part);
        }
  }

  /// The tsdf of every voxel of `box` (NaN when unknown), x-major as readBox's output. Rows along
  /// z are contiguous both in a leaf's buffer and in `out`, so each row is read straight through.
  void readTsdf(const openvdb::CoordBBox& box, float* out) {
    using Leaf = openvdb::Int64Tree::LeafNodeType;
    const openvdb::Coord dim = box.dim();
    forEachLeafPart(box, [&](const openvdb::Coord& origin, const openvdb::CoordBBox& part) {
      // Without a leaf the region holds one tile value (usually the background 0: unknown).
      const Leaf* w_leaf = w_acc_.probeConstLeaf(origin);
      const Leaf* wd_leaf = wd_acc_.probeConstLeaf(origin);
      const std::int64_t w_tile = w_leaf ? 0 : w_acc_.getValue(origin);
      const std::int64_t wd_tile = wd_leaf ? 0 : wd_acc_.getValue(origin);
      const int nz = part.max().z() - part.min().z() + 1;
      for (int x = part.min().x(); x <= part.max().x(); ++x)
        for (int y = part.min().y(); y <= part.max().y(); ++y) {
          const openvdb::Coord first(x, y, part.min().z());
          float* row = out + boxIndex(box.min(), dim, first);
          if (w_leaf && wd_leaf) {
            const std::int64_t* w = w_leaf->buffer().data() + Leaf::coordToOffset(first);
            const std::int64_t* wd = wd_leaf->buffer().data() + Leaf::coordToOffset(first);
            for (int k = 0; k < nz; ++k) row[k] = tsdfOf(w[k], wd[k]);
          } else {
            for (int k = 0; k < nz; ++k) {
              const openvdb::Coord c(x, y, part.min().z() + k);
              row[k] = tsdfOf(w_leaf ? w_leaf->getValue(c) : w_tile, wd_leaf ? wd_leaf->getValue(c) : wd_tile);
            }
          }
        }
    });
  }

  /// The hit count of every voxel of `box`, x-major; rows along z copied straight through, as
  /// readTsdf's.
  void readHits(const openvdb::CoordBBox& box, std::int64_t* out) {
    using Leaf = openvdb::Int64Tree::LeafNodeType;
    const openvdb::Coord dim = box.dim();
    forEachLeafPart(box, [&](const openvdb::Coord& origin, const openvdb::CoordBBox& part) {
      const Leaf* leaf = hits_acc_.probeConstLeaf(origin);
      const std::int64_t tile = leaf ? 0 : hits_acc_.getValue(origin);
      const int nz = part.max().z() - part.min().z() + 1;
      for (int x = part.min().x(); x <= part.max().x(); ++x)
        for (int y = part.min().y(); y <= part.max().y(); ++y) {
          const openvdb::Coord first(x, y, part.min().z());
          std::int64_t* row = out + boxIndex(box.min(), dim, first);
          if (leaf)
            std::copy_n(leaf->buffer().data() + Leaf::coordToOffset(first), nz, row);
          else
            std::fill_n(row, nz, tile);
        }
    });
  }

  openvdb::Int64Grid::ConstPtr w_grid_;
  openvdb::Int64Grid::ConstPtr wd_grid_;
  openvdb::Int64Grid::ConstPtr hits_grid_;
  openvdb::Int64Grid::ConstAccessor w_acc_;
  openvdb::Int64Grid::ConstAccessor wd_acc_;
  openvdb::Int64Grid::ConstAccessor hits_acc_;
  VoxelCodec codec_;
  bool thin_;
  float thin_below_m_;
  float thin_margin_m_;
  bool hit_obstacles_;
  std::int64_t min_hits_;
  std::vector<float> tsdf_;          ///< readBox's scratch
  std::vector<std::int64_t> hits_;  ///< readBox's scratch
};
}  // namespace

void TsdfMapQueryConfig::validate() const {
  if (!(thin_below_vox > 0.0 && thin_below_vox <= 100.0))
    throw std::invalid_argument("TsdfMapQueryConfig.thin_below_vox must be in (0, 100]");
  if (!(thin_margin_vox > 0.0 && thin_margin_vox <= 100.0))
    throw std::invalid_argument("TsdfMapQueryConfig.thin_margin_vox must be in (0, 100]");
  if (!(min_hits >= 1 && min_hits <= 1000000000))
    throw std::invalid_argument("TsdfMapQueryConfig.min_hits must be in [1, 1e9]");
}

TsdfMapQuery::TsdfMapQuery(const TsdfVolume& volume, const TsdfMapQueryConfig& params)
    : volume_(&volume), params_(params) {
  params_.validate();
  if (params_.thin_obstacles || params_.hit_obstacles) {
    TsdfMapQueryConfig own = params_;
    own.thin_obstacles = own.hit_obstacles = false;
    sight_ = std::make_shared<const TsdfMapQuery>(volume, own);
  }
}

const MapQuery& TsdfMapQuery::sightMap() const { return sight_ ? *sight_ : *this; }

double TsdfMapQuery::voxelSize() const { return volume_->config().voxel_size_m; }

openvdb::CoordBBox TsdfMapQuery::knownBounds() const { return volume_->activeBoundingBox(); }

std::unique_ptr<MapReader> TsdfMapQuery::reader() const {
  return std::make_unique<TsdfReader>(volume_->weightSumGrid(), volume_->weightedSdfSumGrid(),
                                      volume_->hitCountGrid(), volume_->config(), params_);
}

}  // namespace vdbmap::planner
