// Set-cover keyframe pruning: compact cell sets, visible cells by a coarse DDA, the lazy greedy
// multi-cover, and the per-block incremental pruner. See vdbmap/set_cover.hpp.
//
// Why the guarantees in the header hold (greedy with counters r(c) = n_ob - cover(c)):
// - Termination: every selection removes one set from the candidates, so at most |sets| rounds.
// - tau_gain < 1: the greedy stops only when the best gain is 0, i.e. no unselected set contains a
//   cell with r(c) > 0. Take any cell c: either r(c) <= 0 (covered >= n_ob times), or every set
//   containing c is selected (covered deg(c) times). So cover(c) >= min(n_ob, deg(c)).
// - tau_gain >= 1: at the stop every unselected set S has gain(S) = |{c in S : r(c) > 0}| <= tau.
//   A cell with cover(c) < min(n_ob, deg(c)) has r(c) > 0 and lies in some unselected set, so the
//   deficient cells are a subset of the union of the unselected sets' still-needed cells: at most
//   floor(tau) per unselected set.
// - Laminar families, n_ob = 1: the maximal sets are pairwise disjoint (two intersecting sets are
//   nested) and every cell of a maximal set M lies only in M or its subsets, so a cover needs a
//   distinct set inside each maximal set: OPT >= number of distinct maximal sets. The greedy takes
//   a largest set, which is maximal; its subsets then have gain 0 and the other sets are disjoint
//   from it and keep their gains, so by induction it takes exactly one set per maximal set.
// - Every cell seen by at most n_ob sets: demand(c) = deg(c), so every set with a cell is needed,
//   and the greedy takes them all (a non-empty unselected set has r(c) >= 1 on each of its cells).
#include "vdbmap/set_cover.hpp"

#include "vdbmap/field_check.hpp"
#include "vdbmap/tsdf_volume.hpp"  // FrameError

#include "internal/grid_dda.hpp"
#include "internal/projective_integrator.hpp"
#include "internal/ray_integrator.hpp"
#include "internal/simd.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <climits>
#include <limits>
#include <cmath>
#include <queue>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

namespace vdbmap {
namespace {

constexpr int kCoordBias = 1 << 20;
/// Above this many bits (16 MiB) the frame's bounding box is too big for a dense bit set.
constexpr std::uint64_t kMaxDenseBits = std::uint64_t(1) << 27;

void requireCellSize(double cell_size_vox) {
  if (!(cell_size_vox >= 1.0 && cell_size_vox <= 64.0)) {
    std::ostringstream msg;
    msg << "cell_size_vox must be in [1, 64], got " << cell_size_vox;
    throw std::invalid_argument(msg.str());
  }
}

void appendVarint(std::vector<std::uint8_t>& out, std::uint64_t v) {
  while (v >= 0x80) {
    out.push_back(std::uint8_t(v | 0x80));
    v >>= 7;
  }
  out.push_back(std::uint8_t(v));
}

/// Visibility counters r(c) in an Int32 tree whose background is n_ob (cells never decremented
/// still need n_ob frames), with a one-leaf cache: consecutive cells of a set share leaves. Only
/// for FramePruner::visibilityCounters(), which shows them as a grid; the greedy uses ColumnCounters.
class CounterGrid {
 public:
  using Tree = openvdb::Int32Tree;
  using Leaf = Tree::LeafNodeType;

  explicit CounterGrid(int n_ob) : tree_(std::make_shared<Tree>(n_ob)), acc_(*tree_) {}

  /// Decrements the counters of the `length` cells from `first` along z, marking them active.
  void decrementRun(openvdb::Coord c, int length) {
    while (length > 0) {
      // z is the fastest index within a leaf: the run's cells in this leaf are contiguous.
      const int count = std::min(length, int(Leaf::DIM) - (c.z() & int(Leaf::DIM - 1)));
      const openvdb::Coord origin = c & ~(Leaf::DIM - 1);
      if (!leaf_ || origin != origin_) {
        leaf_ = acc_.touchLeaf(c);
        origin_ = origin;
      }
      const openvdb::Index n = Leaf::coordToOffset(c);
      for (int i = 0; i < count; ++i) {
        leaf_->setActiveState(n + openvdb::Index(i), true);
        leaf_->buffer().data()[n + openvdb::Index(i)] -= 1;
      }
      c.z() += count;
      length -= count;
    }
  }
  Tree::Ptr tree() const { return tree_; }

 private:
  Tree::Ptr tree_;
  openvdb::tree::ValueAccessor<Tree> acc_;
  Leaf* leaf_ = nullptr;
  openvdb::Coord origin_{INT_MAX};
};

/// The greedy's visibility counters, flat: r(c) counts down from `start` and stops at 0, which is
/// all the greedy asks of it (r(c) > 0 or not). Cells are grouped in columns of 64 along z (z in
/// [64 k, 64 k + 64) at one x, y), and columns in bricks of 4 x 4, allocated as sets reach them. Each
/// column keeps a 64-bit mask of its cells with r(c) > 0, and each set is turned once per solve into
/// its columns and the mask of its cells in each (a frame's cells come in long z runs). A gain is
/// then a popcount per column, with no tree lookups.
class ColumnCounters {
 public:
  struct Column {
    std::uint64_t cells;  ///< bit z & 63 for the set's cells in the column
    std::uint32_t index;
  };

  /// `start` in [1, 65535]: min(n_ob, number of sets) gives the greedy the same answers as n_ob,
  /// because a cell reaches 0 from there only once every set, and so every set holding it, is selected.
  explicit ColumnCounters(std::size_t start) : start_(std::uint16_t(start)) {}

  /// The set's columns, in key order.
  std::vector<Column> columnsOf(const CellSet& set) {
    std::vector<Column> columns;
    set.forEachRun([&](openvdb::Coord c, int length) {
      while (length > 0) {
        const int z = c.z() & (kZ - 1), count = std::min(length, kZ - z);
        const std::uint64_t bits = (count == kZ ? ~std::uint64_t(0) : ((std::uint64_t(1) << count) - 1)) << z;
        const std::uint32_t index = columnIndex(c);
        if (!columns.empty() && columns.back().index == index)
          columns.back().cells |= bits;  // a later run of the same column
        else
          columns.push_back({bits, index});
        c.z() += count;
        length -= count;
      }
    });
    return columns;
  }
  /// Cells of the columns with r(c) > 0.
  std::size_t positive(const std::vector<Column>& columns) const {
#if VDBMAP_AVX2_KERNELS
    if (internal::simdLevel() == internal::SimdLevel::Avx2) return positiveHw(columns);
#endif
    return countPositive(columns);
  }
  void decrement(const std::vector<Column>& columns) {
    for (const Column& c : columns) {
      std::uint16_t* r = counters_.data() + std::size_t(c.index) * kZ;
      for (std::uint64_t bits = c.cells & positive_[c.index]; bits; bits &= bits - 1) {
        const int z = __builtin_ctzll(bits);
        if (--r[z] == 0) positive_[c.index] &= ~(std::uint64_t(1) << z);
      }
    }
  }

 private:
  static constexpr int kXY = 4, kZ = 64;
  static constexpr std::size_t kBrickColumns = std::size_t(kXY * kXY);
  /// Column indices are 32-bit.
  static constexpr std::size_t kMaxBricks = (std::size_t(1) << 32) / kBrickColumns;

  /// positive()'s loop, inlined into each level's caller: the AVX2 one compiles it with the
  /// POPCNT instruction, the baseline with the compiler's portable popcount.
  __attribute__((always_inline)) std::size_t countPositive(const std::vector<Column>& columns) const {
    std::size_t n = 0;
    for (const Column& c : columns) n += std::size_t(__builtin_popcountll(positive_[c.index] & c.cells));
    return n;
  }
#if VDBMAP_AVX2_KERNELS
  /// positive() with the CPU's popcount instruction (every CPU with AVX2 has it).
  VDBMAP_TARGET_AVX2 std::size_t positiveHw(const std::vector<Column>& columns) const { return countPositive(columns); }
#endif

  /// The index of c's column; cells are packable, so c + 2^20 >= 0.
  std::uint32_t columnIndex(const openvdb::Coord& c) {
    const std::uint64_t key = (std::uint64_t((c.x() + kCoordBias) / kXY) << 40) |
                              (std::uint64_t((c.y() + kCoordBias) / kXY) << 20) |
                              std::uint64_t((c.z() + kCoordBias) / kZ);
    if (key != last_key_) {
      const auto [it, added] = bricks_.try_emplace(key, 0u);
      if (added) {
        if (bricks_.size() > kMaxBricks) throw std::length_error("greedyCover: the sets span too many cells");
        it->second = std::uint32_t(positive_.size());
        positive_.resize(positive_.size() + kBrickColumns, ~std::uint64_t(0));
        counters_.resize(counters_.size() + kBrickColumns * kZ, start_);
      }
      last_key_ = key;
      last_first_ = it->second;
    }
    return last_first_ + std::uint32_t((c.x() & (kXY - 1)) * kXY + (c.y() & (kXY - 1)));
  }

  std::uint16_t start_;
  std::unordered_map<std::uint64_t, std::uint32_t> bricks_;  ///< brick key -> its first column
  std::vector<std::uint64_t> positive_;                      ///< per column: bit z & 63 while r > 0
  std::vector<std::uint16_t> counters_;                      ///< r, 64 per column
  std::uint64_t last_key_ = ~std::uint64_t(0);
  std::uint32_t last_first_ = 0;
};

void validateGreedy(int n_ob, double tau_gain) {
  if (n_ob < 1) throw std::invalid_argument("greedyCover: n_ob must be >= 1, got " + std::to_string(n_ob));
  if (!(tau_gain >= 0.0)) {
    std::ostringstream msg;
    msg << "greedyCover: tau_gain must be >= 0, got " << tau_gain;
    throw std::invalid_argument(msg.str());
  }
}

}  // namespace

// ---- config -----------------------------------------------------------------------------------

void SetCoverConfig::validate() const {
  const FieldCheck check("SetCoverConfig");
  check.inRange("n_ob", double(n_ob), 1.0, 1000.0);
  check.inRange("tau_gain", tau_gain, 0.0, 1e9);
  if (!(block_size_m > 0.0 && block_size_m <= 1e4)) check.fail("block_size_m", "(0, 1e4]", block_size_m);
  check.inRange("cell_size_vox", cell_size_vox, 1.0, 64.0);
  check.inRange("solve_period_frames", double(solve_period_frames), 1.0, 1e6);
}

// ---- cells ------------------------------------------------------------------------------------

std::uint64_t packCell(const openvdb::Coord& c) {
  for (int a = 0; a < 3; ++a) {
    if (c[a] < -kCoordBias || c[a] >= kCoordBias) {
      std::ostringstream msg;
      msg << "cell (" << c.x() << ", " << c.y() << ", " << c.z() << ") is outside the packable range [-2^20, 2^20)";
      throw std::out_of_range(msg.str());
    }
  }
  return (std::uint64_t(c.x() + kCoordBias) << 42) | (std::uint64_t(c.y() + kCoordBias) << 21) |
         std::uint64_t(c.z() + kCoordBias);
}

void checkPackable(FrameId id, const Pose3d& T_W_S, const TsdfConfig& tsdf, const IntegratorConfig& integrator,
                   double cell_size_vox) {
  const double cell_m = tsdf.voxel_size_m * cell_size_vox;
  const double reach_cells = (T_W_S.translation().cwiseAbs().maxCoeff() + integrator.max_range_m) / cell_m + 2.0;
  if (!(reach_cells < double(kCoordBias))) {
    std::ostringstream msg;
    msg << "frame " << id << ": T_W_S translation (" << T_W_S.translation().transpose()
        << ") m is beyond the range frame pruning covers (|x|, |y|, |z| + max range < "
        << double(kCoordBias) * cell_m << " m = 2^20 cells of " << cell_m << " m)";
    throw FrameError(msg.str());
  }
}

CellSet CellSet::fromSortedKeys(const std::vector<std::uint64_t>& keys) {
  CellSet s;
  s.bytes_.reserve(keys.size() + keys.size() / 4 + 8);
  std::uint64_t prev = 0;
  for (std::size_t i = 0; i < keys.size(); ++i) {
    if (i > 0 && keys[i] <= prev) throw std::invalid_argument("CellSet::fromSortedKeys: keys must be strictly increasing");
    if (keys[i] >> 63) throw std::invalid_argument("CellSet::fromSortedKeys: not a packed cell key");
    appendVarint(s.bytes_, keys[i] - prev);
    prev = keys[i];
  }
  s.bytes_.shrink_to_fit();
  s.size_ = keys.size();
  return s;
}

CellSet CellSet::fromCoords(std::vector<openvdb::Coord> cells) {
  std::vector<std::uint64_t> keys;
  keys.reserve(cells.size());
  for (const auto& c : cells) keys.push_back(packCell(c));
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return fromSortedKeys(keys);
}

std::vector<openvdb::Coord> CellSet::toCoords() const {
  std::vector<openvdb::Coord> out;
  out.reserve(size_);
  forEach([&](const openvdb::Coord& c) { out.push_back(c); });
  return out;
}

std::vector<std::uint64_t> CellSet::toKeys() const {
  std::vector<std::uint64_t> out;
  out.reserve(size_);
  forEach([&](const openvdb::Coord& c) { out.push_back(packCell(c)); });
  return out;
}

openvdb::Coord cellOf(const Vec3d& p_W, double voxel_size_m, double cell_size_vox) {
  const double s = 1.0 / (voxel_size_m * cell_size_vox), off = 0.5 / cell_size_vox;
  return openvdb::Coord(int(std::floor(p_W.x() * s + off)), int(std::floor(p_W.y() * s + off)),
                        int(std::floor(p_W.z() * s + off)));
}

openvdb::math::Transform::Ptr cellTransform(double voxel_size_m, double cell_size_vox) {
  // Cell c spans x in [(c k - 0.5) v, ((c + 1) k - 0.5) v): its centre is c k v + (k - 1) v / 2.
  auto xform = openvdb::math::Transform::createLinearTransform(voxel_size_m * cell_size_vox);
  const double shift = 0.5 * (cell_size_vox - 1.0) * voxel_size_m;
  xform->postTranslate(openvdb::Vec3d(shift, shift, shift));
  return xform;
}

CellSet visibleCells(const PointCloud& points_S, const Pose3d& T_W_S, const TsdfConfig& tsdf,
                     const IntegratorConfig& integrator, double cell_size_vox) {
  tsdf.validate();
  integrator.validate();
  requireCellSize(cell_size_vox);
  if (!isValidRigidTransform(T_W_S)) throw std::invalid_argument("visibleCells: T_W_S is not a rigid transform");

  IntegrationStats stats;
  const std::vector<internal::RayBundle> bundles = internal::bundleRays(points_S, T_W_S, tsdf, integrator, stats);
  const Vec3d origin_W = T_W_S.translation();
  const double s = 1.0 / (tsdf.voxel_size_m * cell_size_vox);  // cells per metre
  const Vec3d o = origin_W * s + Vec3d::Constant(0.5 / cell_size_vox);  // origin in cell space
  const double delta = tsdf.truncation_m();

  // The segments in cell space: direction and length (metres), as castOne in ray_integrator.cpp.
  struct Segment {
    Vec3d dir;
    double t_end;
  };
  std::vector<Segment> segments;
  segments.reserve(bundles.size());
  openvdb::Coord lo(int(std::floor(o.x())), int(std::floor(o.y())), int(std::floor(o.z()))), hi = lo;
  for (const auto& b : bundles) {
    const Vec3d d = b.end_W - origin_W;
    const double dist = d.norm();
    if (!(dist > 1e-9)) continue;
    const double t_end = b.surface ? dist + delta : dist - delta;
    if (t_end <= 0.0) continue;
    const Vec3d dir = d / dist;
    const Vec3d e = o + dir * (t_end * s);
    const openvdb::Coord ce(int(std::floor(e.x())), int(std::floor(e.y())), int(std::floor(e.z())));
    lo.minComponent(ce);
    hi.maxComponent(ce);
    segments.push_back({dir, t_end});
  }
  for (const auto& c : {lo, hi}) packCell(c);  // throws when the frame is outside the packable range
  lo -= openvdb::Coord(1);                     // one cell of slack for rounding at the segment ends
  hi += openvdb::Coord(1);

  const std::uint64_t nx = std::uint64_t(hi.x() - lo.x() + 1), ny = std::uint64_t(hi.y() - lo.y() + 1),
                      nz = std::uint64_t(hi.z() - lo.z() + 1);
  const bool dense = nx * ny * nz <= kMaxDenseBits;
  std::vector<std::uint64_t> bits(dense ? (nx * ny * nz + 63) / 64 : 0);
  std::vector<std::uint64_t> keys;  // cells outside the box (rounding) or all cells when not dense

  const auto mark = [&](int x, int y, int z) {
    if (dense && x >= lo.x() && x <= hi.x() && y >= lo.y() && y <= hi.y() && z >= lo.z() && z <= hi.z()) {
      const std::uint64_t i = (std::uint64_t(x - lo.x()) * ny + std::uint64_t(y - lo.y())) * nz + std::uint64_t(z - lo.z());
      bits[i >> 6] |= std::uint64_t(1) << (i & 63);
    } else {
      keys.push_back(packCell(openvdb::Coord(x, y, z)));
    }
  };

  // Coarse 3D DDA per segment; t in metres along the ray.
  for (const Segment& seg : segments) {
    internal::GridDda dda(o, seg.dir, s);
    while (true) {
      mark(dda.cell[0], dda.cell[1], dda.cell[2]);
      const int a = dda.nextAxis();
      if (dda.t_max[a] > seg.t_end) break;
      dda.advance(a);
    }
  }
  if (segments.empty()) return CellSet();

  // Bits in index order are cells in key order (x, then y, then z): no sort needed unless some
  // cells fell outside the box.
  std::vector<std::uint64_t> dense_keys;
  for (std::size_t w = 0; w < bits.size(); ++w) {
    std::uint64_t word = bits[w];
    while (word) {
      const std::uint64_t i = std::uint64_t(w) * 64 + std::uint64_t(__builtin_ctzll(word));
      word &= word - 1;
      const std::uint64_t z = i % nz, xy = i / nz;
      const std::uint64_t y = xy % ny, x = xy / ny;
      dense_keys.push_back(packCell(openvdb::Coord(lo.x() + int(x), lo.y() + int(y), lo.z() + int(z))));
    }
  }
  if (!keys.empty()) {
    dense_keys.insert(dense_keys.end(), keys.begin(), keys.end());
    std::sort(dense_keys.begin(), dense_keys.end());
    dense_keys.erase(std::unique(dense_keys.begin(), dense_keys.end()), dense_keys.end());
  }
  return CellSet::fromSortedKeys(dense_keys);
}

namespace {
/// footprintCells for cells of k = 1, 2, 4 or 8 voxels. Leaves (8^3 voxels at origins that are
/// multiples of 8) then hold whole cells, m^3 of them (m = 8 / k), and voxel v lies in cell
/// floor(v / k). A leaf's cells are found from its 64-bit rows, not voxel by voxel, and walking
/// the leaves in key order emits the keys sorted, with no sort.
CellSet alignedFootprintCells(const VoxelFootprint& footprint, int k) {
  const int m = 8 / k;
  // Row masks: in a 64-bit row of a leaf (bit 8 j + l for voxel (i, j, l) at a fixed i), the
  // voxels of cell (b, c) are j in [b k, b k + k), l in [c k, c k + k).
  std::vector<std::uint64_t> cell_rows(std::size_t(m * m), 0);
  for (int j = 0; j < 8; ++j)
    for (int l = 0; l < 8; ++l) cell_rows[std::size_t((j / k) * m + l / k)] |= std::uint64_t(1) << (8 * j + l);
  struct LeafCells {
    openvdb::Coord origin;
    std::array<std::uint64_t, 8> bits{};  // bit (a m + b) m + c of the m^3 <= 512 cells
  };
  std::vector<LeafCells> leaves;
  leaves.reserve(footprint.size());
  for (const LeafFootprint& leaf : footprint) {
    if (leaf.empty()) continue;
    LeafCells cells;
    cells.origin = leaf.origin;
    for (int a = 0; a < m; ++a) {
      std::uint64_t rows = 0;
      for (int i = a * k; i < a * k + k; ++i) rows |= leaf.voxels[std::size_t(i)];
      if (!rows) continue;
      for (int bc = 0; bc < m * m; ++bc)
        if (rows & cell_rows[std::size_t(bc)]) {
          const int bit = a * m * m + bc;
          cells.bits[std::size_t(bit >> 6)] |= std::uint64_t(1) << (bit & 63);
        }
    }
    leaves.push_back(cells);
  }
  // Coord's < is lexicographic in (x, y, z).
  std::sort(leaves.begin(), leaves.end(), [](const LeafCells& p, const LeafCells& q) { return p.origin < q.origin; });
  // A leaf listed twice (footprints list each once, but this costs nothing): its cells merged.
  std::size_t unique = 0;
  for (std::size_t n = 0; n < leaves.size(); ++n) {
    if (unique > 0 && leaves[unique - 1].origin == leaves[n].origin) {
      for (std::size_t w = 0; w < 8; ++w) leaves[unique - 1].bits[w] |= leaves[n].bits[w];
      continue;
    }
    leaves[unique++] = leaves[n];
  }
  leaves.resize(unique);
  const auto has = [m](const LeafCells& l, int a, int b, int c) {
    const int bit = (a * m + b) * m + c;
    return (l.bits[std::size_t(bit >> 6)] >> (bit & 63)) & 1;
  };
  std::vector<std::uint64_t> keys;
  // Key order is x, then y, then z: for each leaf x, each cell x in it; for each leaf y among those
  // leaves, each cell y; then the leaves of that x and y in z order, each cell z.
  for (std::size_t x0 = 0; x0 < leaves.size();) {
    std::size_t x1 = x0;
    while (x1 < leaves.size() && leaves[x1].origin.x() == leaves[x0].origin.x()) ++x1;
    for (int a = 0; a < m; ++a)
      for (std::size_t y0 = x0; y0 < x1;) {
        std::size_t y1 = y0;
        while (y1 < x1 && leaves[y1].origin.y() == leaves[y0].origin.y()) ++y1;
        for (int b = 0; b < m; ++b)
          for (std::size_t n = y0; n < y1; ++n) {
            const openvdb::Coord cell0(leaves[n].origin.x() / k + a, leaves[n].origin.y() / k + b,
                                       leaves[n].origin.z() / k);
            for (int c = 0; c < m; ++c)
              if (has(leaves[n], a, b, c)) keys.push_back(packCell(cell0.offsetBy(0, 0, c)));
          }
        y0 = y1;
      }
    x0 = x1;
  }
  return CellSet::fromSortedKeys(keys);
}
}  // namespace

CellSet footprintCells(const VoxelFootprint& footprint, double cell_size_vox) {
  requireCellSize(cell_size_vox);
  const bool leaf_aligned = std::all_of(footprint.begin(), footprint.end(), [](const LeafFootprint& leaf) {
    return ((leaf.origin.x() | leaf.origin.y() | leaf.origin.z()) & 7) == 0;
  });
  for (const int k : {1, 2, 4, 8})
    if (leaf_aligned && cell_size_vox == double(k)) return alignedFootprintCells(footprint, k);
  // Voxel v lies in cell floor((v + 0.5) / k): its centre v * voxel in cell space (see cellTransform).
  const double inv_k = 1.0 / cell_size_vox;
  const auto cellOfIndex = [inv_k](int v) { return int(std::floor((double(v) + 0.5) * inv_k)); };
  std::vector<std::uint64_t> keys;
  for (const LeafFootprint& leaf : footprint) {
    // The leaf's cells, deduplicated in a small dense box before they join the frame's list.
    const openvdb::Coord c0(cellOfIndex(leaf.origin.x()), cellOfIndex(leaf.origin.y()), cellOfIndex(leaf.origin.z()));
    const openvdb::Coord c1(cellOfIndex(leaf.origin.x() + 7), cellOfIndex(leaf.origin.y() + 7),
                            cellOfIndex(leaf.origin.z() + 7));
    const openvdb::Coord dim = c1 - c0 + openvdb::Coord(1);
    std::vector<char> seen(std::size_t(dim.x()) * std::size_t(dim.y()) * std::size_t(dim.z()), 0);
    for (int w = 0; w < 8; ++w)
      for (std::uint64_t word = leaf.voxels[std::size_t(w)]; word; word &= word - 1) {
        const int n = w * 64 + __builtin_ctzll(word);  // n = 64 i + 8 j + k
        const openvdb::Coord c(cellOfIndex(leaf.origin.x() + (n >> 6)), cellOfIndex(leaf.origin.y() + ((n >> 3) & 7)),
                               cellOfIndex(leaf.origin.z() + (n & 7)));
        const openvdb::Coord d = c - c0;
        char& s = seen[(std::size_t(d.x()) * std::size_t(dim.y()) + std::size_t(d.y())) * std::size_t(dim.z()) + std::size_t(d.z())];
        if (!s) {
          s = 1;
          keys.push_back(packCell(c));
        }
      }
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return CellSet::fromSortedKeys(keys);
}

CellSet visibleCells(const DepthImage& depth_m, const CameraIntrinsics& K, const Pose3d& T_W_S, const TsdfConfig& tsdf,
                     const IntegratorConfig& integrator, double cell_size_vox) {
  if (integrator.ray_mode != RayMode::Projective) return visibleCells(backProject(depth_m, K), T_W_S, tsdf, integrator, cell_size_vox);
  tsdf.validate();
  integrator.validate();
  requireCellSize(cell_size_vox);
  if (!isValidRigidTransform(T_W_S)) throw std::invalid_argument("visibleCells: T_W_S is not a rigid transform");
  return footprintCells(internal::projectiveFootprint(depth_m, K, T_W_S, tsdf, integrator), cell_size_vox);
}

// ---- greedy -----------------------------------------------------------------------------------

std::vector<std::size_t> greedyCover(const std::vector<const CellSet*>& sets, int n_ob, double tau_gain) {
  initializeOpenVdb();
  validateGreedy(n_ob, tau_gain);
  for (std::size_t i = 0; i < sets.size(); ++i)
    if (!sets[i]) throw std::invalid_argument("greedyCover: set " + std::to_string(i) + " is null");

  // Max-heap on (gain, -index): the largest gain first, the lowest index among equal gains.
  struct Entry {
    std::size_t gain;
    std::size_t index;
  };
  const auto lower = [](const Entry& a, const Entry& b) {
    return a.gain < b.gain || (a.gain == b.gain && a.index > b.index);
  };
  std::priority_queue<Entry, std::vector<Entry>, decltype(lower)> heap(lower);
  // evaluated_at[i]: the number of selections made when set i's gain was last computed. All
  // counters start at n_ob >= 1, so the initial gains (the set sizes) are exact at 0 selections.
  std::vector<std::size_t> evaluated_at(sets.size(), 0);
  for (std::size_t i = 0; i < sets.size(); ++i)
    if (double(sets[i]->size()) > tau_gain) heap.push({sets[i]->size(), i});

  const std::size_t start = std::min(std::size_t(n_ob), sets.size());
  if (start > 65535) throw std::invalid_argument("greedyCover: n_ob and the number of sets are both above 65535");
  ColumnCounters counters(std::max<std::size_t>(start, 1));
  std::vector<std::vector<ColumnCounters::Column>> columns(sets.size());
  for (std::size_t i = 0; i < sets.size(); ++i)
    if (double(sets[i]->size()) > tau_gain) columns[i] = counters.columnsOf(*sets[i]);
  std::vector<std::size_t> selected;
  while (!heap.empty()) {
    const Entry top = heap.top();
    heap.pop();
    std::vector<ColumnCounters::Column>& top_columns = columns[top.index];
    if (evaluated_at[top.index] == selected.size()) {
      // Exact and not below any other entry's upper bound: the true greedy choice. Its gain is
      // > tau_gain because entries at or below tau_gain are never pushed.
      counters.decrement(top_columns);
      std::vector<ColumnCounters::Column>().swap(top_columns);  // never looked at again
      selected.push_back(top.index);
      continue;
    }
    const std::size_t gain = counters.positive(top_columns);
    evaluated_at[top.index] = selected.size();
    if (double(gain) > tau_gain)
      heap.push({gain, top.index});
    else
      std::vector<ColumnCounters::Column>().swap(top_columns);  // gains only fall: never again
  }
  return selected;
}

std::vector<std::size_t> greedyCover(const std::vector<std::vector<openvdb::Coord>>& sets, int n_ob,
                                     double tau_gain) {
  validateGreedy(n_ob, tau_gain);
  std::vector<CellSet> compact;
  compact.reserve(sets.size());
  for (const auto& s : sets) compact.push_back(CellSet::fromCoords(s));
  std::vector<const CellSet*> ptrs;
  ptrs.reserve(compact.size());
  for (const auto& s : compact) ptrs.push_back(&s);
  return greedyCover(ptrs, n_ob, tau_gain);
}

// ---- pruner -----------------------------------------------------------------------------------

FramePruner::FramePruner(const SetCoverConfig& config, double voxel_size_m)
    : config_(config), voxel_size_m_(voxel_size_m) {
  config_.validate();
  if (!(voxel_size_m > 0.0 && voxel_size_m <= 10.0)) {
    std::ostringstream msg;
    msg << "FramePruner: voxel_size_m must be in (0, 10], got " << voxel_size_m;
    throw std::invalid_argument(msg.str());
  }
}

FramePruner::BlockKey FramePruner::blockOf(const Vec3d& p) const {
  const double inv = 1.0 / config_.block_size_m;
  return BlockKey(int(std::floor(p.x() * inv)), int(std::floor(p.y() * inv)), int(std::floor(p.z() * inv)));
}

void FramePruner::requirePosition(const char* what, FrameId id, const Vec3d& camera_position_W) const {
  if (!camera_position_W.allFinite() ||
      (camera_position_W.array().abs() / config_.block_size_m).maxCoeff() >= double(INT_MAX))
    throw std::invalid_argument(std::string("FramePruner::") + what + ": frame " + std::to_string(id) +
                                " has a non-finite or out-of-range camera position");
}

void FramePruner::addFrame(FrameId id, const Vec3d& camera_position_W, CellSet cells) {
  if (frames_.count(id)) throw std::invalid_argument("FramePruner::addFrame: frame " + std::to_string(id) + " is already held");
  requirePosition("addFrame", id, camera_position_W);
  const BlockKey key = blockOf(camera_position_W);
  Block& block = blocks_[key];
  block.frames.insert(std::upper_bound(block.frames.begin(), block.frames.end(), id), id);
  block.dirty = true;
  frames_.emplace(id, Frame{key, std::make_shared<const CellSet>(std::move(cells))});
}

void FramePruner::removeFrame(FrameId id) {
  const auto it = frames_.find(id);
  if (it == frames_.end()) throw std::invalid_argument("FramePruner::removeFrame: frame " + std::to_string(id) + " is not held");
  const auto b = blocks_.find(it->second.block);
  auto& ids = b->second.frames;
  ids.erase(std::lower_bound(ids.begin(), ids.end(), id));
  if (ids.empty()) blocks_.erase(b);
  frames_.erase(it);
}

void FramePruner::updateFrame(FrameId id, const Vec3d& camera_position_W, CellSet cells) {
  if (!frames_.count(id)) throw std::invalid_argument("FramePruner::updateFrame: frame " + std::to_string(id) + " is not held");
  requirePosition("updateFrame", id, camera_position_W);
  removeFrame(id);
  addFrame(id, camera_position_W, std::move(cells));
}

const CellSet& FramePruner::cellsOf(FrameId id) const {
  const auto it = frames_.find(id);
  if (it == frames_.end()) throw std::invalid_argument("FramePruner::cellsOf: frame " + std::to_string(id) + " is not held");
  return *it->second.cells;
}

std::size_t FramePruner::dirtyBlockCount() const {
  std::size_t n = 0;
  for (const auto& [key, block] : blocks_) n += block.dirty;
  return n;
}

std::vector<FrameId> FramePruner::framesInBlock(const BlockKey& block) const {
  const auto it = blocks_.find(block);
  return it == blocks_.end() ? std::vector<FrameId>{} : it->second.frames;
}

void PruningSolve::run() {
  if (has_run_) throw std::logic_error("PruningSolve::run: the solve has already run");
  // Blocks are independent (own counters, disjoint frames).
  const auto solveBlock = [this](Block& block) {
    std::vector<const CellSet*> sets;
    sets.reserve(block.sets.size());
    for (const auto& set : block.sets) sets.push_back(set.get());
    block.selected = greedyCover(sets, n_ob_, tau_gain_);
  };
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks_.size(), 1), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t b = r.begin(); b != r.end(); ++b) solveBlock(blocks_[b]);
  });
  has_run_ = true;
}

FramePruner::Result FramePruner::solve() {
  PruningSolve job = beginSolve();
  job.run();
  return finishSolve(std::move(job));
}

PruningSolve FramePruner::beginSolve() {
  PruningSolve job;
  job.n_ob_ = config_.n_ob;
  job.tau_gain_ = config_.tau_gain;
  for (auto& [key, block] : blocks_) {
    if (!block.dirty) continue;
    PruningSolve::Block taken;
    taken.key = key;
    taken.ids = block.frames;
    taken.sets.reserve(block.frames.size());
    for (const FrameId id : block.frames) taken.sets.push_back(frames_.at(id).cells);
    job.blocks_.push_back(std::move(taken));
    block.dirty = false;
  }
  return job;
}

FramePruner::Result FramePruner::finishSolve(PruningSolve&& job) {
  if (!job.has_run_) throw std::logic_error("FramePruner::finishSolve: the solve has not run");
  Result result;
  for (const PruningSolve::Block& taken : job.blocks_) {
    std::vector<char> keep(taken.ids.size(), 0);
    for (const std::size_t i : taken.selected) keep[i] = 1;
    for (std::size_t i = 0; i < taken.ids.size(); ++i) {
      const auto it = frames_.find(taken.ids[i]);
      // Unchanged since beginSolve: still held with the very cell set the solve saw.
      if (keep[i] || it == frames_.end() || it->second.cells != taken.sets[i]) continue;
      result.dropped.push_back(taken.ids[i]);
      removeFrame(taken.ids[i]);
    }
    result.solved_blocks.push_back(taken.key);
  }
  result.blocks_solved = job.blocks_.size();
  result.frames_kept = frames_.size();
  return result;
}

std::size_t FramePruner::memoryBytes() const {
  std::size_t bytes = sizeof(*this);
  // unordered_map: one node per frame (value + next pointer + cached hash) and the bucket array.
  bytes += frames_.size() * (sizeof(std::pair<const FrameId, Frame>) + 2 * sizeof(void*)) +
           frames_.bucket_count() * sizeof(void*);
  for (const auto& [id, frame] : frames_) bytes += sizeof(CellSet) + frame.cells->memoryBytes();
  // std::map: one node per block (value + three pointers + colour).
  for (const auto& [key, block] : blocks_)
    bytes += sizeof(std::pair<const BlockKey, Block>) + 4 * sizeof(void*) + block.frames.capacity() * sizeof(FrameId);
  return bytes;
}

openvdb::Int32Grid::Ptr FramePruner::visibilityCounters(const BlockKey& block) const {
  initializeOpenVdb();
  CounterGrid counters(config_.n_ob);
  const auto it = blocks_.find(block);
  if (it != blocks_.end())
    for (const FrameId id : it->second.frames)
      frames_.at(id).cells->forEachRun([&](const openvdb::Coord& c, int n) { counters.decrementRun(c, n); });
  auto grid = openvdb::Int32Grid::create(counters.tree());
  grid->setTransform(cellTransform(voxel_size_m_, config_.cell_size_vox));
  grid->setName("visibility_counters");
  return grid;
}

}  // namespace vdbmap
