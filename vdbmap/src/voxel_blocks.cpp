#include "internal/voxel_blocks.hpp"

#include "internal/free_list.hpp"
#include "internal/prune_leaves.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstring>

namespace vdbmap::internal {

KeyIndex::KeyIndex(std::size_t expected) {
  std::size_t cap = 16;
  while (cap < 2 * expected) cap <<= 1;
  keys_.resize(cap);
  slots_.assign(cap, kEmpty);
}

void KeyIndex::grow() {
  std::vector<std::uint64_t> keys = std::move(keys_);
  std::vector<std::uint32_t> slots = std::move(slots_);
  keys_.assign(keys.size() * 2, 0);
  slots_.assign(slots.size() * 2, kEmpty);
  for (std::size_t j = 0; j < slots.size(); ++j) {
    if (slots[j] == kEmpty) continue;
    std::size_t i = mixHash(keys[j]) & (slots_.size() - 1);
    while (slots_[i] != kEmpty) i = (i + 1) & (slots_.size() - 1);
    keys_[i] = keys[j];
    slots_[i] = slots[j];
  }
}

bool Block::anyTouched() const {
  return std::any_of(touched.begin(), touched.end(), [](std::uint64_t w) { return w != 0; });
}

namespace {

/// Blocks are 12 KiB each and a frame uses thousands: kept for the next frame, up to 72 MiB.
FreeList<Block>& pool() {
  static FreeList<Block> p(6144);
  return p;
}

}  // namespace

std::unique_ptr<Block> acquireBlock(const openvdb::Coord& origin) {
  std::unique_ptr<Block> b = pool().take();
  if (!b) {
    b = std::make_unique<Block>();
    b->touched.fill(0);
    b->free_w.fill(0);
    std::memset(b->band.data(), 0, sizeof(b->band));
  }
  b->origin = origin;
  return b;
}

void releaseBlocks(std::vector<std::unique_ptr<Block>>& blocks) { pool().keep(blocks); }
void releaseBlock(std::unique_ptr<Block> block) { pool().keep(std::move(block)); }

bool addBlockToLeaves(Block& block, Int64Leaf& w_leaf, Int64Leaf& wd_leaf, std::int64_t sign) {
  std::int64_t* w_data = w_leaf.buffer().data();
  std::int64_t* wd_data = wd_leaf.buffer().data();
  bool emptied = false;
  for (std::size_t word = 0; word < block.touched.size(); ++word) {
    std::uint64_t bits = block.touched[word];
    while (bits) {
      const openvdb::Index n = openvdb::Index(word * 64 + std::size_t(__builtin_ctzll(bits)));
      bits &= bits - 1;
      Block::Cell& band = block.band[n];
      std::int64_t& free = block.free_w[n];
      const std::int64_t w = w_data[n] + sign * (band.w + free);
      const std::int64_t wd = wd_data[n] + sign * (band.wd + free * kSdfScale);
      band = {0, 0};  // back to the pool zeroed
      free = 0;
      if (w == 0) {  // every contribution to this voxel is gone: remove it
        w_data[n] = 0;
        wd_data[n] = 0;
        w_leaf.setActiveState(n, false);
        wd_leaf.setActiveState(n, false);
        emptied = true;
      } else {
        w_data[n] = w;
        wd_data[n] = wd;
        w_leaf.setActiveState(n, true);
        wd_leaf.setActiveState(n, true);
      }
    }
    block.touched[word] = 0;
  }
  return emptied;
}

void applyBlocks(const std::vector<Block*>& blocks, openvdb::Int64Tree& weight, openvdb::Int64Tree& wsdf,
                 std::int64_t sign) {
  // A DDA or a frustum test may visit a leaf without updating it: such blocks create no leaf.
  std::vector<std::pair<std::uint64_t, Block*>> all;
  all.reserve(blocks.size());
  for (Block* b : blocks)
    if (b->anyTouched()) all.emplace_back(blockKey(b->origin), b);
  if (all.empty()) return;
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.first < b.first; });

  // Topology changes are serial (OpenVDB trees are not thread-safe for writes); values are not.
  struct Target {
    std::size_t begin, end;  // range in `all`
    Int64Leaf* w;
    Int64Leaf* wd;
  };
  std::vector<Target> targets;
  openvdb::tree::ValueAccessor<openvdb::Int64Tree> wacc(weight), wdacc(wsdf);
  for (std::size_t i = 0; i < all.size();) {
    std::size_t j = i + 1;
    while (j < all.size() && all[j].first == all[i].first) ++j;
    const openvdb::Coord& origin = all[i].second->origin;
    targets.push_back({i, j, wacc.touchLeaf(origin), wdacc.touchLeaf(origin)});
    i = j;
  }

  std::vector<char> emptied(targets.size(), 0);  // whether a voxel of the target was removed
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, targets.size(), 16), [&](const auto& r) {
    for (std::size_t t = r.begin(); t != r.end(); ++t) {
      const Target& target = targets[t];
      for (std::size_t k = target.begin; k != target.end; ++k)
        if (addBlockToLeaves(*all[k].second, *target.w, *target.wd, sign)) emptied[t] = 1;
    }
  });
  std::vector<openvdb::Coord> prune;
  for (std::size_t t = 0; t < targets.size(); ++t)
    if (emptied[t]) prune.push_back(targets[t].w->origin());
  pruneEmptiedLeaves(weight, prune);
  pruneEmptiedLeaves(wsdf, std::move(prune));
}

}  // namespace vdbmap::internal
