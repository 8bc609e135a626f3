// Pending voxel updates of one frame, in leaf-shaped blocks, and their exact application to the
// map (private to the library). Both integrators (rays and projective) fill blocks; applyBlocks
// adds them into the OpenVDB trees leaf by leaf, in parallel, creating leaves as needed; the
// projective integrator adds a block to a leaf the map has (addBlockToLeaves) as soon as it is full.
#pragma once

#include "vdbmap/config.hpp"
#include "vdbmap/openvdb.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

namespace vdbmap::internal {

using Int64Leaf = openvdb::Int64Tree::LeafNodeType;

/// Fixed point of the behind-surface drop-off factor.
inline constexpr std::int64_t kFractionScale = 1 << 16;

/// Rounds half away from zero, like std::llround, without the libm call (hot loops).
inline std::int64_t roundToInt64(double x) { return std::int64_t(x < 0.0 ? x - 0.5 : x + 0.5); }

/// floor(x) as an int without the libm call; equal to int(std::floor(x)) for |x| < 2^31.
inline int fastFloor(double x) {
  const int i = int(x);
  return i - int(x < double(i));
}

inline std::size_t mixHash(std::uint64_t k) {
  k ^= k >> 33;
  k *= 0xff51afd7ed558ccdULL;
  k ^= k >> 33;
  return std::size_t(k);
}

/// Open-addressing map from 64-bit keys to dense indices 0..n-1 in insertion order.
class KeyIndex {
 public:
  explicit KeyIndex(std::size_t expected);
  /// The index of `key`, inserting it as `size()` when new; `inserted` says which.
  std::uint32_t findOrInsert(std::uint64_t key, bool& inserted) {
    if (2 * (size_ + 1) > slots_.size()) grow();
    std::size_t i = mixHash(key) & (slots_.size() - 1);
    while (slots_[i] != kEmpty) {
      if (keys_[i] == key) {
        inserted = false;
        return slots_[i];
      }
      i = (i + 1) & (slots_.size() - 1);
    }
    keys_[i] = key;
    slots_[i] = std::uint32_t(size_);
    inserted = true;
    return std::uint32_t(size_++);
  }
  std::size_t size() const { return size_; }
  /// Keys it holds before it grows.
  std::size_t capacity() const { return slots_.size() / 2; }

 private:
  static constexpr std::uint32_t kEmpty = std::numeric_limits<std::uint32_t>::max();
  void grow();
  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> slots_;
  std::size_t size_ = 0;
};

/// One leaf's worth (8^3 voxels, OpenVDB's leaf layout) of pending updates. Free-space updates
/// (sdf clamped to +truncation) all have the form (w, w * kSdfScale), so they only sum their
/// weight, in an array of their own: most updates are free space, and this halves their memory
/// traffic. Band updates keep (W, WD) interleaved, one cache line per update.
struct Block {
  struct Cell {
    std::int64_t w, wd;
  };
  openvdb::Coord origin;
  std::array<std::uint64_t, Int64Leaf::SIZE / 64> touched;  // bit n: voxel n holds an update
  std::array<std::int64_t, Int64Leaf::SIZE> free_w;         // summed free-space weights
  std::array<Cell, Int64Leaf::SIZE> band;                   // summed band updates

  void addFree(openvdb::Index n, std::int64_t w) {
    free_w[n] += w;
    touched[n >> 6] |= std::uint64_t(1) << (n & 63);
  }
  void addBand(openvdb::Index n, std::int64_t w, std::int64_t wd) {
    band[n].w += w;
    band[n].wd += wd;
    touched[n >> 6] |= std::uint64_t(1) << (n & 63);
  }
  bool anyTouched() const;
};

/// A zeroed block from a process-wide pool (blocks are recycled between frames: zeroing fresh
/// ones costs more than an integration). Thread-safe.
std::unique_ptr<Block> acquireBlock(const openvdb::Coord& origin);
/// Returns blocks to the pool; they must be zero again (applyBlocks leaves them so).
void releaseBlocks(std::vector<std::unique_ptr<Block>>& blocks);
void releaseBlock(std::unique_ptr<Block> block);

/// Key of a leaf origin (a multiple of 8 per axis) that sorts like openvdb::Coord (x, y, z).
inline std::uint64_t blockKey(const openvdb::Coord& origin) {
  constexpr std::uint64_t bias = 1u << 20, mask = (1u << 21) - 1;
  return ((std::uint64_t((origin.x() >> 3) + bias) & mask) << 42) |
         ((std::uint64_t((origin.y() >> 3) + bias) & mask) << 21) | (std::uint64_t((origin.z() >> 3) + bias) & mask);
}

/// The update one ray (or one pixel) of fixed-point weight `weight_q` gives a voxel at signed
/// distance `sdf` metres from the surface along it (DESIGN section 4): +truncation and beyond is
/// free space; within the band the sdf is quantized, with the paper's linear drop-off of the
/// 1/z^2 weight behind the surface; further behind, nothing.
class SdfUpdate {
 public:
  explicit SdfUpdate(const TsdfConfig& tsdf)
      : delta_(tsdf.truncation_m()),
        inv_delta_(1.0 / delta_),
        epsilon_(tsdf.voxel_size_m),
        drop_off_(tsdf.weighting == Weighting::InverseSquare) {}

  double truncation() const { return delta_; }

  /// Adds sign (+1 or -1) times the update to voxel n of `block`; returns whether there was one.
  bool apply(Block& block, openvdb::Index n, double sdf, std::int64_t weight_q, std::int64_t sign = 1) const {
    if (sdf >= delta_) {
      block.addFree(n, sign * weight_q);
      return true;
    }
    if (!(sdf >= -delta_)) return false;
    std::int64_t w = weight_q;
    if (drop_off_ && sdf < -epsilon_) {
      const double f = delta_ > epsilon_ ? (delta_ + sdf) / (delta_ - epsilon_) : 0.0;
      w = (w * roundToInt64(f * kFractionScale)) / kFractionScale;
    }
    if (w <= 0) return false;
    block.addBand(n, sign * w, sign * w * roundToInt64(sdf * inv_delta_ * double(kSdfScale)));
    return true;
  }

 private:
  double delta_, inv_delta_, epsilon_;
  bool drop_off_;
};

/// Adds sign * (the block's updates) into the leaves of W and WD at its origin and zeroes the
/// block. A voxel whose weight returns to 0 is switched off (value 0); returns whether one was, so
/// that the caller prunes the leaf when it holds no other (pruneEmptiedLeaves). Changes values and
/// active states only: threads may apply blocks to different leaves at once.
bool addBlockToLeaves(Block& block, Int64Leaf& w_leaf, Int64Leaf& wd_leaf, std::int64_t sign);

/// Adds sign * (the blocks' updates) into W and WD, leaf by leaf in parallel. Blocks without any
/// update create no leaf; voxels whose weight returns to 0 are removed and then empty branches
/// pruned. Leaves the blocks zeroed (ready for releaseBlocks). Several blocks may share an origin
/// (e.g. one per thread). Block values may be negative (a re-integration's net change).
void applyBlocks(const std::vector<Block*>& blocks, openvdb::Int64Tree& weight, openvdb::Int64Tree& wsdf,
                 std::int64_t sign);

}  // namespace vdbmap::internal
