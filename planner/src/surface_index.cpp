#include "vdbmap/planner/surface_index.hpp"

#include <algorithm>

namespace vdbmap::planner {

namespace {
/// Voxels added on every side when a box grows, so that a set that moves with the vehicle
/// grows it rarely.
constexpr int kGrowVoxels = 8;
/// The box is fitted to the set again when it holds this many times the set's bounds (with margin).
constexpr std::size_t kShrinkFactor = 2;
}  // namespace

void SurfaceIndex::insert(const openvdb::Coord& ijk) {
  if (contains(ijk)) return;
  if (reserve(ijk))
    setBit(ijk, true);
  else
    outside_.insert(ijk);
  ++size_;
  count(ijk, 1);
}

void SurfaceIndex::erase(const openvdb::Coord& ijk) {
  if (!contains(ijk)) return;
  if (box_.isInside(ijk))
    setBit(ijk, false);
  else
    outside_.erase(ijk);
  --size_;
  count(ijk, -1);
  // A set that moved on leaves most of the box empty: fit it again, so that lookups stay within
  // few cache lines (rarely: only once the box is kShrinkFactor times the bounds with margin).
  if (size_ > 0 && outside_.empty()) {
    const openvdb::CoordBBox fitted = bounds_.expandBy(kGrowVoxels);
    if (box_.volume() > kShrinkFactor * fitted.volume()) rebox(fitted);
  }
}

void SurfaceIndex::clear() { *this = SurfaceIndex(); }

void SurfaceIndex::setBit(const openvdb::Coord& ijk, bool on) {
  const std::size_t i = boxIndex(box_.min(), dim_, ijk);
  const std::uint64_t bit = std::uint64_t(1) << (i % 64);
  bits_[i / 64] = on ? bits_[i / 64] | bit : bits_[i / 64] & ~bit;
}

bool SurfaceIndex::reserve(const openvdb::Coord& ijk) {
  if (box_.isInside(ijk)) return true;
  // The box grown to ijk with a margin; too large, the set's own bounds and ijk, with less margin.
  const auto withMargin = [&ijk](openvdb::CoordBBox box, int margin) {
    box.expand(ijk);
    box.expand(box.min().offsetBy(-margin));
    box.expand(box.max().offsetBy(margin));
    return box;
  };
  for (const openvdb::CoordBBox& candidate : {withMargin(box_, kGrowVoxels), withMargin(bounds_, kGrowVoxels),
                                              withMargin(bounds_, kGrowVoxels / 4), withMargin(bounds_, 0)})
    if (candidate.volume() <= kMaxVoxels) {
      rebox(candidate);
      return true;
    }
  return false;
}

void SurfaceIndex::rebox(const openvdb::CoordBBox& box) {
  std::vector<openvdb::Coord> voxels(outside_.begin(), outside_.end());
  const std::size_t plane = std::size_t(dim_.y()) * std::size_t(dim_.z());
  for (std::size_t w = 0; w < bits_.size(); ++w)
    for (std::uint64_t word = bits_[w]; word != 0; word &= word - 1) {  // each set bit, lowest first
      const std::size_t i = 64 * w + std::size_t(__builtin_ctzll(word)), in_plane = i % plane;
      voxels.push_back(box_.min().offsetBy(int(i / plane), int(in_plane / std::size_t(dim_.z())),
                                           int(in_plane % std::size_t(dim_.z()))));
    }
  box_ = box;
  dim_ = box.dim();
  bits_.assign((box.volume() + 63) / 64, 0);
  outside_.clear();
  for (const openvdb::Coord& c : voxels) {
    if (box_.isInside(c))
      setBit(c, true);
    else
      outside_.insert(c);
  }
}

void SurfaceIndex::count(const openvdb::Coord& ijk, int change) {
  for (int k = 0; k < 3; ++k) {
    std::vector<std::int32_t>& h = histogram_[k];
    int at = ijk[k] - histogram_min_[k];
    if (h.empty() || at < 0 || at >= int(h.size())) {  // grow the axis's range (only on insert)
      const int lo = h.empty() ? ijk[k] - kGrowVoxels : std::min(histogram_min_[k], ijk[k] - kGrowVoxels);
      const int hi =
          h.empty() ? ijk[k] + kGrowVoxels : std::max(histogram_min_[k] + int(h.size()) - 1, ijk[k] + kGrowVoxels);
      std::vector<std::int32_t> grown(std::size_t(hi - lo + 1), 0);
      if (!h.empty()) std::copy(h.begin(), h.end(), grown.begin() + (histogram_min_[k] - lo));
      h.swap(grown);
      histogram_min_[k] = lo;
      at = ijk[k] - lo;
    }
    h[std::size_t(at)] += change;
  }
  if (change > 0) {
    bounds_.expand(ijk);
    return;
  }
  if (size_ == 0) {
    bounds_ = openvdb::CoordBBox();
    return;
  }
  // A bound whose last voxel left moves in to the next coordinate that holds one.
  openvdb::Coord lo = bounds_.min(), hi = bounds_.max();
  for (int k = 0; k < 3; ++k) {
    const std::vector<std::int32_t>& h = histogram_[k];
    while (h[std::size_t(lo[k] - histogram_min_[k])] == 0) ++lo[k];
    while (h[std::size_t(hi[k] - histogram_min_[k])] == 0) --hi[k];
  }
  bounds_ = openvdb::CoordBBox(lo, hi);
}

}  // namespace vdbmap::planner
