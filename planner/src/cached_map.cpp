#include "vdbmap/planner/cached_map.hpp"

namespace vdbmap::planner {

namespace {
constexpr int kLog2Block = 3;  ///< blocks of 8^3 voxels, aligned as OpenVDB's leaves
constexpr int kBlockSide = 1 << kLog2Block;

openvdb::Coord blockOf(const openvdb::Coord& ijk) {
  // Arithmetic shifts: floor division by 8, also for negative coordinates.
  return openvdb::Coord(ijk.x() >> kLog2Block, ijk.y() >> kLog2Block, ijk.z() >> kLog2Block);
}
}  // namespace

struct CachedMap::Block {
  Occupancy states[kBlockSide * kBlockSide * kBlockSide];  ///< z fastest (boxIndex)
};

/// Answers from the shared blocks, filling a missing one through its own base reader.
class CachedMap::Reader : public MapReader {
 public:
  explicit Reader(const CachedMap& map) : map_(map), base_(map.base_->reader()) {}

  Occupancy at(const openvdb::Coord& ijk) override {
    std::atomic<const Block*>* slot = map_.slot(ijk);
    if (!slot) return base_->at(ijk);
    const Block* block = slot->load(std::memory_order_acquire);
    if (!block) block = fill(*slot, ijk);
    const int m = kBlockSide - 1;
    return block->states[((ijk.x() & m) << (2 * kLog2Block)) | ((ijk.y() & m) << kLog2Block) | (ijk.z() & m)];
  }

  /// Whole boxes (frontier scans, viewpoint scoring) are read from the base directly.
  void readBox(const openvdb::CoordBBox& box, Occupancy* out) override { base_->readBox(box, out); }

 private:
  const Block* fill(std::atomic<const Block*>& slot, const openvdb::Coord& ijk) {
    auto block = std::make_unique<Block>();
    const openvdb::Coord lo(ijk.x() & ~(kBlockSide - 1), ijk.y() & ~(kBlockSide - 1), ijk.z() & ~(kBlockSide - 1));
    base_->readBox(openvdb::CoordBBox(lo, lo.offsetBy(kBlockSide - 1)), block->states);
    const Block* expected = nullptr;
    if (slot.compare_exchange_strong(expected, block.get(), std::memory_order_acq_rel, std::memory_order_acquire)) {
      map_.blocks_read_.fetch_add(1, std::memory_order_relaxed);
      return block.release();
    }
    return expected;  // another reader filled it first, with the same states
  }

  const CachedMap& map_;
  std::unique_ptr<MapReader> base_;
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
