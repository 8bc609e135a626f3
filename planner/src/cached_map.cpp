#include "vdbmap/planner/cached_map.hpp"

#include <algorithm>
#include <cstdint>
#include <memory>
#include <vector>

namespace vdbmap::planner {

namespace {
constexpr int kLog2Block = 3;  ///< blocks of 8^3 voxels, aligned as OpenVDB's leaves
constexpr int kBlockSide = 1 << kLog2Block;

openvdb::Coord blockOf(const openvdb::Coord& ijk) {
  // Arithmetic shifts: floor division by 8, also for negative coordinates.
  return openvdb::Coord(ijk.x() >> kLog2Block, ijk.y() >> kLog2Block, ijk.z() >> kLog2Block);
}
/// The first voxel of a block (block coordinates).
openvdb::Coord originOf(const openvdb::Coord& block) {
  return openvdb::Coord(block.x() * kBlockSide, block.y() * kBlockSide, block.z() * kBlockSide);
}
/// The most voxels fillMissing reads at once (a buffer of one byte per voxel).
constexpr std::uint64_t kMaxWideRead = std::uint64_t{1} << 21;
}  // namespace

struct CachedMap::Block {
  Occupancy states[kBlockSide * kBlockSide * kBlockSide];  ///< z fastest (boxIndex)
};

/// Answers from the shared blocks, filling a missing one through its own base reader. Queries
/// come in runs within one block, so the last block used is kept at hand.
class CachedMap::Reader : public MapReader {
 public:
  explicit Reader(const CachedMap& map) : map_(map), base_(map.base_->reader()) {}

  Occupancy at(const openvdb::Coord& ijk) override {
    const Block* block = blockAt(ijk);
    return block ? block->states[indexInBlock(ijk)] : base_->at(ijk);
  }

  /// Block by block: from the cached blocks (filling those it needs), and from the base for the
  /// parts of the box beyond them.
  void readBox(const openvdb::CoordBBox& box, Occupancy* out) override {
    const openvdb::Coord dim = box.dim();
    const openvdb::Coord lo_block = blockOf(box.min()), hi_block = blockOf(box.max());
    if (lo_block == hi_block) {  // the usual case: a run of a few voxels
      const Block* block = blockAt(box.min());
      if (!block) {
        base_->readBox(box, out);
        return;
      }
      const int nz = dim.z();
      for (int x = box.min().x(); x <= box.max().x(); ++x)
        for (int y = box.min().y(); y <= box.max().y(); ++y, out += nz)
          std::copy_n(&block->states[indexInBlock(openvdb::Coord(x, y, box.min().z()))], nz, out);
      return;
    }
    fillMissing(lo_block, hi_block);
    for (int bx = lo_block.x(); bx <= hi_block.x(); ++bx)
      for (int by = lo_block.y(); by <= hi_block.y(); ++by)
        for (int bz = lo_block.z(); bz <= hi_block.z(); ++bz) {
          const openvdb::Coord origin = originOf(openvdb::Coord(bx, by, bz));
          openvdb::CoordBBox part(origin, origin.offsetBy(kBlockSide - 1));
          part.intersect(box);
          const Block* block = blockAt(origin);
          const Occupancy* from = block ? block->states : beyond(part);
          const openvdb::Coord from_min = block ? origin : part.min(),
                               from_dim = block ? openvdb::Coord(kBlockSide) : part.dim();
          const int nz = part.max().z() - part.min().z() + 1;
          for (int x = part.min().x(); x <= part.max().x(); ++x)
            for (int y = part.min().y(); y <= part.max().y(); ++y) {
              const openvdb::Coord row(x, y, part.min().z());
              std::copy_n(from + boxIndex(from_min, from_dim, row), nz, out + boxIndex(box.min(), dim, row));
            }
        }
  }

 private:
  static int indexInBlock(const openvdb::Coord& ijk) {
    const int m = kBlockSide - 1;
    return ((ijk.x() & m) << (2 * kLog2Block)) | ((ijk.y() & m) << kLog2Block) | (ijk.z() & m);
  }

  /// The block holding ijk (read now if no reader has yet), or nullptr outside the cached blocks.
  const Block* blockAt(const openvdb::Coord& ijk) {
    const openvdb::Coord b = blockOf(ijk);
    if (last_ && b == last_coord_) return last_;
    std::atomic<const Block*>* slot = map_.slot(ijk);
    if (!slot) return nullptr;
    const Block* block = slot->load(std::memory_order_acquire);
    if (!block) block = fill(*slot, ijk);
    last_coord_ = b;
    last_ = block;
    return block;
  }

  /// The states of a part of a block outside the cached ones, from the base (valid until the next call).
  const Occupancy* beyond(const openvdb::CoordBBox& part) {
    base_->readBox(part, beyond_.states);
    return beyond_.states;
  }

  /// Fills the missing blocks among those from lo_block to hi_block (block coordinates) with one
  /// read of the base where they are most of the blocks spanning them: a base read costs per box
  /// too (the TSDF map reads a one-voxel border for its neighbour rules, and each leaf once per
  /// box), so one box of many blocks is cheaper than each block alone. The states are the same.
  void fillMissing(const openvdb::Coord& lo_block, const openvdb::Coord& hi_block) {
    openvdb::CoordBBox missing;  // in block coordinates
    std::size_t count = 0;
    for (int bx = lo_block.x(); bx <= hi_block.x(); ++bx)
      for (int by = lo_block.y(); by <= hi_block.y(); ++by)
        for (int bz = lo_block.z(); bz <= hi_block.z(); ++bz) {
          const openvdb::Coord b(bx, by, bz);
          const std::atomic<const Block*>* slot = map_.slot(originOf(b));
          if (!slot || slot->load(std::memory_order_acquire)) continue;
          missing.expand(b);
          ++count;
        }
    if (count < 2 || 2 * count < missing.volume()) return;  // block by block, as read
    const openvdb::CoordBBox voxels(originOf(missing.min()), originOf(missing.max()).offsetBy(kBlockSide - 1));
    if (voxels.volume() > kMaxWideRead) return;
    const openvdb::Coord dim = voxels.dim();
    wide_.resize(std::size_t(voxels.volume()));
    base_->readBox(voxels, wide_.data());
    for (int bx = missing.min().x(); bx <= missing.max().x(); ++bx)
      for (int by = missing.min().y(); by <= missing.max().y(); ++by)
        for (int bz = missing.min().z(); bz <= missing.max().z(); ++bz) {
          const openvdb::Coord origin = originOf(openvdb::Coord(bx, by, bz));
          std::atomic<const Block*>* slot = map_.slot(origin);
          if (!slot || slot->load(std::memory_order_acquire)) continue;
          auto block = std::make_unique<Block>();
          for (int x = 0; x < kBlockSide; ++x)
            for (int y = 0; y < kBlockSide; ++y)
              std::copy_n(&wide_[std::size_t(boxIndex(voxels.min(), dim, origin.offsetBy(x, y, 0)))], kBlockSide,
                          &block->states[indexInBlock(origin.offsetBy(x, y, 0))]);
          publish(*slot, std::move(block));
        }
  }

  /// Stores a block read into its slot, unless another reader stored one first (with the same
  /// states); returns the block kept.
  const Block* publish(std::atomic<const Block*>& slot, std::unique_ptr<Block> block) {
    const Block* expected = nullptr;
    if (slot.compare_exchange_strong(expected, block.get(), std::memory_order_acq_rel, std::memory_order_acquire)) {
      map_.blocks_read_.fetch_add(1, std::memory_order_relaxed);
      return block.release();
    }
    return expected;
  }

  const Block* fill(std::atomic<const Block*>& slot, const openvdb::Coord& ijk) {
    auto block = std::make_unique<Block>();
    const openvdb::Coord lo = originOf(blockOf(ijk));
    base_->readBox(openvdb::CoordBBox(lo, lo.offsetBy(kBlockSide - 1)), block->states);
    return publish(slot, std::move(block));
  }

  const CachedMap& map_;
  std::unique_ptr<MapReader> base_;
  openvdb::Coord last_coord_;  ///< block coordinates (voxel >> 3) of last_
  const Block* last_ = nullptr;
  Block beyond_;  ///< beyond()'s buffer
  std::vector<Occupancy> wide_;  ///< fillMissing()'s buffer
};

CachedMap::CachedMap(const MapQuery& base, std::size_t max_blocks)
    : base_(&base), voxel_size_m_(base.voxelSize()), max_blocks_(max_blocks) {}

CachedMap::~CachedMap() {
  if (!table_) return;
  const std::size_t n = std::size_t(blocks_dim_.x()) * std::size_t(blocks_dim_.y()) * std::size_t(blocks_dim_.z());
  for (std::size_t i = 0; i < n; ++i) delete table_[i].load(std::memory_order_relaxed);
}

void CachedMap::init() const {
  std::call_once(init_once_, [this] {
    bounds_ = base_->knownBounds();
    if (bounds_.empty()) return;
    first_block_ = blockOf(bounds_.min());
    const openvdb::Coord dim = blockOf(bounds_.max()) - first_block_ + openvdb::Coord(1);
    const double count = double(dim.x()) * double(dim.y()) * double(dim.z());
    if (count > double(max_blocks_)) return;
    blocks_dim_ = dim;
    table_ = std::make_unique<std::atomic<const Block*>[]>(std::size_t(count));
    for (std::size_t i = 0; i < std::size_t(count); ++i) table_[i].store(nullptr, std::memory_order_relaxed);
  });
}

openvdb::CoordBBox CachedMap::knownBounds() const {
  init();
  return bounds_;
}

std::atomic<const CachedMap::Block*>* CachedMap::slot(const openvdb::Coord& ijk) const {
  const openvdb::Coord b = blockOf(ijk) - first_block_;
  if (b.x() < 0 || b.y() < 0 || b.z() < 0 || b.x() >= blocks_dim_.x() || b.y() >= blocks_dim_.y() ||
      b.z() >= blocks_dim_.z())
    return nullptr;
  return &table_[(std::size_t(b.x()) * std::size_t(blocks_dim_.y()) + std::size_t(b.y())) *
                     std::size_t(blocks_dim_.z()) +
                 std::size_t(b.z())];
}

std::unique_ptr<MapReader> CachedMap::reader() const {
  init();
  return std::make_unique<Reader>(*this);
}

const MapQuery& CachedMap::sightMap() const {
  const MapQuery& sight = base_->sightMap();
  if (&sight == base_) return *this;
  std::call_once(sight_once_, [&] { sight_ = std::make_unique<const CachedMap>(sight, max_blocks_); });
  return *sight_;
}

}  // namespace vdbmap::planner
