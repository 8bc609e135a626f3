// Set-cover keyframe pruning (Zhang et al., ICRA 2022, Sect. IV-C, Algorithm 1).
//
// Universe: a coarse grid whose cells are `cell_size_vox` voxels wide (2 by default). A frame's set
// is every coarse cell its rays touch, free space included (visibleCells). Each cell carries a
// visibility counter that starts at n_ob; a cell "still needs" coverage while its counter is > 0.
// A frame's gain is the number of its cells whose counter is > 0. The greedy repeatedly selects the
// frame with the largest gain (every frame costs 1, so this is the paper's cost-per-new-cell rule),
// decrements the counters of all its cells, and stops when the best gain is <= tau_gain. Frames
// not selected are dropped (the caller de-integrates and releases them).
//
// Guarantees of greedyCover (proved in set_cover.cpp, checked in tests/vdbmap/test_set_cover.cpp):
// - tau_gain < 1 (e.g. 0): every cell c ends covered by at least min(n_ob, deg(c)) selected sets,
//   where deg(c) is the number of input sets that contain c.
// - tau_gain >= 1: every set left out contains at most floor(tau_gain) cells that are still
//   under-covered (counter > 0), so at most floor(tau_gain) * (number of left-out sets) cells end
//   covered fewer than min(n_ob, deg(c)) times, and those cells lie only in left-out sets.
// - n_ob = 1, tau_gain = 0 is the classic greedy set cover (ln-approximation); on laminar families
//   (any two sets nested or disjoint) it returns a minimum cover, as does any n_ob when no cell is
//   seen by more than n_ob sets (then every non-empty set is needed).
//
// Cell coordinates: with voxel i spanning [i - 0.5, i + 0.5) * voxel_size (OpenVDB's centres),
// cell c spans u in [c k, (c + 1) k) where u = x / voxel_size + 0.5 and k = cell_size_vox; for
// k = 2 cell c is exactly voxels {2c, 2c + 1}. Coordinates must lie in [-2^20, 2^20) (about 100 km
// at 0.1 m cells) because cells are packed into 64-bit keys.
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/config.hpp"
#include "vdbmap/openvdb.hpp"
#include "vdbmap/types.hpp"
#include "vdbmap/voxel_footprint.hpp"

#include <cstdint>
#include <map>
#include <memory>
#include <unordered_map>
#include <vector>

namespace vdbmap {

/// Parameters of set-cover pruning.
struct SetCoverConfig {
  /// Initial visibility counter: how many kept frames should see each cell. [1, 1000]
  int n_ob = 3;
  /// Stop when the best gain (cells that still need coverage) is <= this. [0, 1e9]
  /// Default 50 cells (0.05 m^3 at 0.1 m cells): a 640x480, 5 m frame touches 10^4-10^5 cells, so a
  /// frame adding under ~0.1-0.5 % of that is not worth storing and re-integrating; the shortfall it
  /// leaves is bounded as stated above (at most 50 cells per dropped frame).
  double tau_gain = 50.0;
  /// Blocks partition space by camera position; each block is solved on its own. (0, 1e4]
  double block_size_m = 5.0;
  /// Coarse cell edge in voxels (the paper: 2). [1, 64]
  double cell_size_vox = 2.0;
  /// How often the mapper calls FramePruner::solve(): every this many added frames. A dirty block
  /// is re-solved over all its current frames, so solving more often costs more time but keeps
  /// fewer redundant frames in memory between solves. [1, 1e6]
  int solve_period_frames = 20;
  /// Where the mapper runs a solve. true: on a worker thread, started every solve_period_frames
  /// frames and collected when the next one is due or the mapper drains, so no frame's cycle waits
  /// for the greedy unless the previous solve is still running; the frames it drops wait one
  /// period longer. false: inside the addFrame that triggers it, its drops queued at once. Either
  /// way the results depend on frame counts only, never on timing.
  bool solve_in_background = true;

  /// Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};

/// A set of coarse cells stored compactly: the packed 64-bit keys, sorted, delta-encoded as LEB128
/// varints. Cells along z are neighbours in key order, so a frustum costs ~1-2 bytes per cell.
class CellSet {
 public:
  CellSet() = default;
  /// From any list of cells (duplicates are merged). Throws std::out_of_range when a coordinate is
  /// outside [-2^20, 2^20).
  static CellSet fromCoords(std::vector<openvdb::Coord> cells);
  /// From strictly increasing packed keys (see packCell); throws std::invalid_argument otherwise.
  static CellSet fromSortedKeys(const std::vector<std::uint64_t>& keys);

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  /// Heap bytes of the encoding.
  std::size_t memoryBytes() const { return bytes_.capacity(); }
  std::vector<openvdb::Coord> toCoords() const;
  std::vector<std::uint64_t> toKeys() const;

  /// Calls fn(const openvdb::Coord&) for every cell in key order (x, then y, then z ascending).
  template <typename Fn>
  void forEach(Fn&& fn) const;
  /// Calls fn(const openvdb::Coord& first, int length) for every maximal run of cells consecutive
  /// along z (first, first + (0, 0, 1), ..., first + (0, 0, length - 1)), in key order. A frame's
  /// cells come in long z runs, so per-run work (e.g. one tree lookup) replaces per-cell work.
  template <typename Fn>
  void forEachRun(Fn&& fn) const;

  friend bool operator==(const CellSet& a, const CellSet& b) { return a.size_ == b.size_ && a.bytes_ == b.bytes_; }

 private:
  /// Reads one LEB128 varint at p and moves p past it.
  static std::uint64_t readVarint(const std::uint8_t*& p) {
    std::uint64_t value = 0;
    int shift = 0;
    std::uint8_t byte;
    do {
      byte = *p++;
      value |= std::uint64_t(byte & 0x7f) << shift;
      shift += 7;
    } while (byte & 0x80);
    return value;
  }

  std::vector<std::uint8_t> bytes_;
  std::size_t size_ = 0;
};

/// Packs a cell into a 64-bit key ordered by (x, y, z); throws std::out_of_range outside [-2^20, 2^20).
std::uint64_t packCell(const openvdb::Coord& c);
openvdb::Coord unpackCell(std::uint64_t key);
/// Throws FrameError naming frame `id` unless every cell within the integrator's max range of the
/// sensor at T_W_S packs (the pruner's limit, checked before a frame changes any state).
void checkPackable(FrameId id, const Pose3d& T_W_S, const TsdfConfig& tsdf, const IntegratorConfig& integrator,
                   double cell_size_vox);

/// The coarse cell (cell_size_vox voxels wide) that contains the world point p_W.
openvdb::Coord cellOf(const Vec3d& p_W, double voxel_size_m, double cell_size_vox);

/// The transform of a coarse-cell grid: index c maps to the centre of cell c in metres.
openvdb::math::Transform::Ptr cellTransform(double voxel_size_m, double cell_size_vox);

/// The coarse cells the frame's rays touch, free space included. The rays are the integrator's
/// (internal::bundleRays with `integrator`; point clouds under Projective are Merged) and each is walked with a
/// coarse 3D DDA over the same extent as the TSDF integration: from the sensor origin to the end
/// point + truncation for surface rays, and to max range - truncation for carve-only rays (points
/// beyond max_range_m). Invalid points are skipped. Uses TBB (bundling) like the integrator.
CellSet visibleCells(const PointCloud& points_S, const Pose3d& T_W_S, const TsdfConfig& tsdf,
                     const IntegratorConfig& integrator, double cell_size_vox);

/// The coarse cells of a depth image (metres, intrinsics K) seen from T_W_S: under Projective
/// integration, the cells of exactly the voxels that integrating it updates (the integrator's own
/// per-voxel tests, free space included), so frustum edges seen by few pixels count too; under the
/// ray modes, the cells of its back-projected points' rays as above.
CellSet visibleCells(const DepthImage& depth_m, const CameraIntrinsics& K, const Pose3d& T_W_S, const TsdfConfig& tsdf,
                     const IntegratorConfig& integrator, double cell_size_vox);

/// The coarse cells of a voxel footprint (the voxels an integration updated, e.g. from
/// TsdfVolume::integrate): what visibleCells() gives for the same frame and pose under Projective
/// integration, without projecting the frame again.
CellSet footprintCells(const VoxelFootprint& footprint, double cell_size_vox);

/// Greedy multi-cover over explicit sets (see the header comment). Returns the indices of the
/// selected sets in selection order; ties are broken by the lowest index. Lazy evaluation: a
/// set's gain only decreases, so stale gains are upper bounds and only the top one is refreshed;
/// the result equals the plain greedy's exactly. Duplicate cells within one set count once.
/// Throws std::invalid_argument when n_ob < 1 or tau_gain is negative or NaN, or when n_ob and the
/// number of sets both exceed 65535 (the counters are 16-bit).
std::vector<std::size_t> greedyCover(const std::vector<std::vector<openvdb::Coord>>& sets, int n_ob,
                                     double tau_gain);
std::vector<std::size_t> greedyCover(const std::vector<const CellSet*>& sets, int n_ob, double tau_gain);

/// One solve of a FramePruner's dirty blocks over the cell sets they held when
/// FramePruner::beginSolve() took them. run() reads only what it holds (cell sets are shared,
/// immutable), so it may run on another thread while the pruner takes new frames, updates and
/// removals; FramePruner::finishSolve() applies it.
class PruningSolve {
 public:
  /// Runs the greedy on each block taken (blocks in parallel). Call once.
  void run();
  bool hasRun() const { return has_run_; }
  /// Blocks taken by beginSolve().
  std::size_t blockCount() const { return blocks_.size(); }

 private:
  friend class FramePruner;
  struct Block {
    openvdb::Coord key;
    std::vector<FrameId> ids;                          ///< ascending
    std::vector<std::shared_ptr<const CellSet>> sets;  ///< sets[i] is ids[i]'s, as taken
    std::vector<std::size_t> selected;                 ///< greedyCover's result, after run()
  };
  std::vector<Block> blocks_;
  int n_ob_ = 1;
  double tau_gain_ = 0.0;
  bool has_run_ = false;
};

/// Incremental pruner. Frames are added with their cells and camera position; the camera position
/// picks the frame's block (floor(p / block_size_m) per axis). solve() re-solves only blocks that
/// got frames since their last solve, each from scratch over all its current frames (the paper's
/// incremental scheme), with its own visibility counters. So a frame kept by an earlier solve can
/// be dropped by a later solve of its block when newer frames cover its cells; a dropped frame is
/// gone for good. Ties go to the older frame (lower FrameId), which keeps earlier choices stable.
/// Removing a frame does not make its block dirty.
class FramePruner {
 public:
  /// Identifies a block: floor(camera position / block_size_m) per axis.
  using BlockKey = openvdb::Coord;

  FramePruner(const SetCoverConfig& config, double voxel_size_m);

  /// Throws std::invalid_argument when the id is already held or the position is not finite.
  void addFrame(FrameId id, const Vec3d& camera_position_W, CellSet cells);
  void addFrame(FrameId id, const Vec3d& camera_position_W, const std::vector<openvdb::Coord>& cells) {
    addFrame(id, camera_position_W, CellSet::fromCoords(cells));
  }
  /// Replaces a held frame's cells and camera position (the frame was re-integrated at a corrected
  /// pose), so later solves see it where it now is. Its block, which may change with the position,
  /// becomes dirty. Throws std::invalid_argument as addFrame() does, or when the id is not held.
  void updateFrame(FrameId id, const Vec3d& camera_position_W, CellSet cells);
  /// Forgets a frame (e.g. the mapper dropped it for another reason). Throws std::invalid_argument
  /// when the id is not held.
  void removeFrame(FrameId id);

  struct Result {
    std::vector<FrameId> dropped;   ///< to de-integrate and release; already forgotten here
    std::size_t blocks_solved = 0;  ///< how many dirty blocks were re-solved
    std::size_t frames_kept = 0;    ///< frames held after the solve, over all blocks
    std::vector<BlockKey> solved_blocks;  ///< which blocks were re-solved, in key order
  };
  /// Re-solves every dirty block; clean blocks are not touched. The same as
  /// finishSolve(run beginSolve()).
  Result solve();
  /// Takes the dirty blocks' frames and cells for a solve and marks the blocks clean (a frame
  /// added or updated later makes its block dirty again).
  PruningSolve beginSolve();
  /// Drops the frames the solve left out, except frames updated or removed since beginSolve():
  /// their new cells were not in the solve (an updated frame's block is dirty, so the next solve
  /// sees it where it now is). Throws std::logic_error when the solve has not run.
  Result finishSolve(PruningSolve&& solve);

  std::size_t dirtyBlockCount() const;
  std::size_t blockCount() const { return blocks_.size(); }
  std::size_t frameCount() const { return frames_.size(); }
  /// True while the frame is held: added, and neither dropped by a solve nor removed.
  bool isKept(FrameId id) const { return frames_.count(id) != 0; }
  /// A held frame's cells; throws std::invalid_argument when the id is not held.
  const CellSet& cellsOf(FrameId id) const;
  BlockKey blockOf(const Vec3d& camera_position_W) const;
  /// The frames held in a block, ascending (empty for an unknown block).
  std::vector<FrameId> framesInBlock(const BlockKey& block) const;
  /// Heap bytes held (cell sets, frame and block tables), approximate for the hash tables.
  std::size_t memoryBytes() const;

  /// The block's visibility counters as the greedy leaves them: an Int32Grid in coarse-cell index
  /// space (transform from cellTransform) with background n_ob, each touched cell holding
  /// n_ob - (number of the block's held frames that see it); values <= 0 mean "covered n_ob
  /// times". Counters are per block. Computed on demand from the held frames, so after a solve of
  /// the block it equals the solver's final state.
  openvdb::Int32Grid::Ptr visibilityCounters(const BlockKey& block) const;

  const SetCoverConfig& config() const { return config_; }
  double voxelSizeM() const { return voxel_size_m_; }

 private:
  struct Frame {
    BlockKey block;
    std::shared_ptr<const CellSet> cells;  ///< shared with solves in flight; replaced, never changed
  };
  struct BlockKeyLess {
    bool operator()(const BlockKey& a, const BlockKey& b) const { return a < b; }
  };
  struct Block {
    std::vector<FrameId> frames;  // ascending
    bool dirty = false;
  };

  void requirePosition(const char* what, FrameId id, const Vec3d& camera_position_W) const;

  SetCoverConfig config_;
  double voxel_size_m_;
  std::unordered_map<FrameId, Frame> frames_;
  std::map<BlockKey, Block, BlockKeyLess> blocks_;
};

// ---- inline ---------------------------------------------------------------------------------------

template <typename Fn>
void CellSet::forEach(Fn&& fn) const {
  std::uint64_t key = 0;
  const std::uint8_t* p = bytes_.data();
  for (std::size_t i = 0; i < size_; ++i) {
    key += readVarint(p);
    fn(unpackCell(key));
  }
}

template <typename Fn>
void CellSet::forEachRun(Fn&& fn) const {
  constexpr std::uint64_t z_mask = (std::uint64_t(1) << 21) - 1;
  std::uint64_t key = 0, first = 0;
  int length = 0;
  const std::uint8_t* p = bytes_.data();
  for (std::size_t i = 0; i < size_; ++i) {
    const std::uint64_t delta = readVarint(p);
    // The next key continues the run when it is the next z of the same column (z's field does not
    // carry into y's).
    if (length > 0 && delta == 1 && (key & z_mask) != z_mask) {
      key += 1;
      ++length;
      continue;
    }
    if (length > 0) fn(unpackCell(first), length);
    key += delta;
    first = key;
    length = 1;
  }
  if (length > 0) fn(unpackCell(first), length);
}

inline openvdb::Coord unpackCell(std::uint64_t key) {
  constexpr std::uint64_t mask = (std::uint64_t(1) << 21) - 1;
  constexpr int bias = 1 << 20;
  return openvdb::Coord(int((key >> 42) & mask) - bias, int((key >> 21) & mask) - bias, int(key & mask) - bias);
}

}  // namespace vdbmap
