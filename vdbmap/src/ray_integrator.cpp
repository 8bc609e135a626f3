#include "internal/ray_integrator.hpp"

#include "internal/grid_dda.hpp"
#include "internal/voxel_blocks.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

namespace vdbmap::internal {
namespace {

constexpr double kMicrometresPerMetre = 1e6;
/// Points are classified and run-length bundled in fixed chunks, so the result does not depend on
/// how TBB splits the work.
constexpr std::size_t kPointChunk = 4096;

/// 21 bits per axis plus the surface flag; coordinates wrap beyond +-2^20 voxels (100 km at 0.1 m).
inline std::uint64_t packKey(const openvdb::Coord& c, bool surface) {
  constexpr std::uint64_t mask = (1u << 21) - 1;
  return (std::uint64_t(surface) << 63) | ((std::uint64_t(c.x()) & mask) << 42) |
         ((std::uint64_t(c.y()) & mask) << 21) | (std::uint64_t(c.z()) & mask);
}

struct Classified {
  Vec3d end_W;
  std::int64_t weight_q;
  bool surface;
};

/// Turns sensor-frame points into ray end points in the world with their weights. Hot: every
/// point of every frame passes here, so the pose is unpacked once and ranges compare squared.
class PointClassifier {
 public:
  PointClassifier(const Pose3d& T_W_S, const TsdfConfig& tsdf, const IntegratorConfig& in)
      : R_(T_W_S.linear()),
        t_(T_W_S.translation()),
        min2_(in.min_range_m * in.min_range_m),
        max2_(in.max_range_m * in.max_range_m),
        max_range_(in.max_range_m),
        scale_(weightScaleFor(tsdf, in)),
        constant_(tsdf.weighting == Weighting::Constant) {}

  /// Returns false (and counts it) when the point is invalid: NaN, infinite, zero, or closer than
  /// min range. Points beyond max range become carve-only rays ending at max range.
  bool operator()(const Vec3f& p, IntegrationStats& stats, Classified& out) const {
    if (!p.allFinite()) {
      ++stats.points_invalid;
      return false;
    }
    Vec3d p_S = p.cast<double>();
    const double r2 = p_S.squaredNorm();
    if (!(r2 > 0.0) || r2 < min2_) {
      ++stats.points_invalid;
      return false;
    }
    double z = p_S.z() > 0.0 ? p_S.z() : std::sqrt(r2);  // depth along the optical axis
    out.surface = r2 <= max2_;
    if (!out.surface) {
      const double s = max_range_ / std::sqrt(r2);
      p_S *= s;
      z *= s;
    }
    out.weight_q = constant_ ? scale_ : roundToInt64(double(scale_) / (z * z));
    if (out.weight_q == 0) {  // only with a weight scale too small for the range: counted, not lost silently
      ++stats.points_invalid;
      return false;
    }
    if (!out.surface) ++stats.points_beyond_range;
    out.end_W = R_ * p_S + t_;
    return true;
  }

 private:
  Eigen::Matrix3d R_;
  Vec3d t_;
  double min2_, max2_, max_range_;
  std::int64_t scale_;
  bool constant_;
};

/// Integer sums of the points that end in one voxel (a bundle before its mean is taken).
struct BundleSum {
  std::uint64_t key = 0;
  std::int64_t x_um = 0, y_um = 0, z_um = 0;  // summed end points in micrometres
  std::int64_t count = 0;
  std::int64_t weight_q = 0;
  bool surface = true;

  void add(const BundleSum& o) {
    x_um += o.x_um;
    y_um += o.y_um;
    z_um += o.z_um;
    count += o.count;
    weight_q += o.weight_q;
  }
};

struct ChunkResult {
  std::vector<BundleSum> runs;  // consecutive points with the same key, in point order
  IntegrationStats stats;
};

// ---- per-thread accumulation of voxel updates -------------------------------------------------

class BlockAccumulator {
 public:
  BlockAccumulator() : index_(256) {}

  /// The block holding the leaf at `origin` (a multiple of 8 per axis), created on first use.
  Block* blockAt(const openvdb::Coord& origin) {
    bool inserted = false;
    const std::uint32_t i = index_.findOrInsert(blockKey(origin), inserted);
    if (inserted) blocks.push_back(acquireBlock(origin));
    return blocks[i].get();
  }

  std::vector<std::unique_ptr<Block>> blocks;
  std::size_t updates = 0;

 private:
  KeyIndex index_;
};

/// A cursor on the voxel a DDA is in: its block and offset in it, updated incrementally so that a
/// step within a leaf costs an add, and only a step across a leaf boundary looks a block up.
class VoxelCursor {
 public:
  VoxelCursor(BlockAccumulator& acc, const int ijk[3]) : acc_(acc) {
    for (int a = 0; a < 3; ++a) local_[a] = ijk[a] & 7;
    origin_ = openvdb::Coord(ijk[0] & ~7, ijk[1] & ~7, ijk[2] & ~7);
    block_ = acc_.blockAt(origin_);
    n_ = Int64Leaf::coordToOffset(openvdb::Coord(ijk[0], ijk[1], ijk[2]));
  }
  /// A free-space update: (dw, dw * kSdfScale).
  void addFree(std::int64_t dw) {
    block_->addFree(n_, dw);
    ++acc_.updates;
  }
  /// The update of a voxel at signed distance sdf (see SdfUpdate).
  void add(const SdfUpdate& update, double sdf, std::int64_t weight_q) {
    if (update.apply(*block_, n_, sdf, weight_q)) ++acc_.updates;
  }
  /// Moves one voxel along axis a (0, 1, 2) in direction step (+1 or -1).
  void move(int a, int step) {
    static constexpr openvdb::Index kStride[3] = {64, 8, 1};
    const int next = local_[a] + step;
    if (next >= 0 && next < 8) {
      local_[a] = next;
      n_ = step > 0 ? n_ + kStride[a] : n_ - kStride[a];
      return;
    }
    local_[a] = next & 7;
    origin_[a] += step * 8;
    block_ = acc_.blockAt(origin_);
    n_ = openvdb::Index(local_[0] * 64 + local_[1] * 8 + local_[2]);
  }

 private:
  BlockAccumulator& acc_;
  Block* block_;
  openvdb::Coord origin_;
  int local_[3];
  openvdb::Index n_;
};

/// Walks the voxels of one bundle with a 3D DDA (Amanatides & Woo) and adds its updates: first the
/// voxels certainly in free space (cheap), then the truncation band around the end point.
void castOne(const RayBundle& b, const Vec3d& origin_W, const TsdfConfig& tsdf, BlockAccumulator& out) {
  const double vs = tsdf.voxel_size_m, inv_vs = 1.0 / vs;
  const double delta = tsdf.truncation_m();
  const Vec3d d = b.end_W - origin_W;
  const double dist = d.norm();
  if (!(dist > 1e-9)) return;
  const Vec3d dir = d / dist;
  const double t_end = b.surface ? dist + delta : dist - delta;
  if (t_end <= 0.0 || b.weight_q <= 0) return;

  // Index space shifted by +0.5, where voxel i spans [i, i + 1).
  GridDda dda(origin_W * inv_vs + Vec3d::Constant(0.5), dir, inv_vs);
  const int* ijk = dda.cell;
  VoxelCursor cursor(out, ijk);
  // One DDA step: to the next voxel along the axis whose boundary comes first; false when the ray
  // ends in the current voxel. `t_exit` gets the ray parameter where the current voxel is left.
  double t_exit = 0.0;
  auto advance = [&]() {
    const int a = dda.nextAxis();
    t_exit = dda.t_max[a];
    if (t_exit > t_end) return false;
    dda.advance(a);
    cursor.move(a, dda.step[a]);
    return true;
  };

  // Free space: sdf = dist - (c - origin) . dir is clamped to +delta, so the update is constant. A
  // voxel entered at ray parameter t has its centre's projection within t + sqrt(3) voxels, so
  // while t < dist - delta - sqrt(3) voxels its sdf is certainly >= delta. Carve-only rays (beyond
  // max range) are free all along.
  const std::int64_t free_w = b.weight_q;
  const double t_free = b.surface ? dist - delta - std::sqrt(3.0) * vs : std::numeric_limits<double>::infinity();
  while (t_exit < t_free) {  // t_exit of the previous voxel = t at which this one was entered
    cursor.addFree(free_w);
    if (!advance()) return;
  }

  // The band: the projective sdf per voxel, clamped, with the paper's drop-off behind the surface.
  const SdfUpdate update(tsdf);
  const Vec3d step_dir = vs * dir;
  const double base = dist + origin_W.dot(dir);
  do {
    const double sdf = base - (ijk[0] * step_dir[0] + ijk[1] * step_dir[1] + ijk[2] * step_dir[2]);
    cursor.add(update, sdf, b.weight_q);
  } while (advance());
}

/// Interleaves the low 16 bits of x and y (Morton / Z order).
inline std::uint32_t interleave16(std::uint32_t x, std::uint32_t y) {
  auto spread = [](std::uint32_t v) {
    v &= 0xffff;
    v = (v | (v << 8)) & 0x00ff00ff;
    v = (v | (v << 4)) & 0x0f0f0f0f;
    v = (v | (v << 2)) & 0x33333333;
    v = (v | (v << 1)) & 0x55555555;
    return v;
  };
  return spread(x) | (spread(y) << 1);
}

/// Orders bundles along a Z curve over their direction from the sensor, so rays cast one after
/// the other are angular neighbours whose voxels are still in cache, and each thread's share of
/// the rays is one compact cone. The map does not depend on the order (integer sums).
void sortByDirection(std::vector<RayBundle>& bundles, const Vec3d& origin_W, double voxel_size_m) {
  // Angular bins about one voxel wide at 5 m; azimuth in [-pi, pi], elevation in [-pi/2, pi/2].
  const double bin = voxel_size_m / 5.0;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> keys(bundles.size());
  for (std::size_t i = 0; i < bundles.size(); ++i) {
    const Vec3d d = bundles[i].end_W - origin_W;
    const double azimuth = std::atan2(d.y(), d.x());
    const double elevation = std::atan2(d.z(), std::hypot(d.x(), d.y()));
    const auto a = std::uint32_t(std::max(0.0, (azimuth + M_PI) / bin));
    const auto e = std::uint32_t(std::max(0.0, (elevation + M_PI / 2) / bin));
    keys[i] = {interleave16(a, e), std::uint32_t(i)};
  }
  std::sort(keys.begin(), keys.end());
  std::vector<RayBundle> sorted;
  sorted.reserve(bundles.size());
  for (const auto& k : keys) sorted.push_back(bundles[k.second]);
  bundles.swap(sorted);
}

}  // namespace

std::vector<RayBundle> bundleRays(const PointCloud& points_S, const Pose3d& T_W_S, const TsdfConfig& tsdf,
                                  const IntegratorConfig& integrator, IntegrationStats& stats) {
  stats.points_total += points_S.size();
  const std::size_t chunks = (points_S.size() + kPointChunk - 1) / kPointChunk;
  const bool merged = integrator.ray_mode != RayMode::PerRay;  // point clouds under Projective: Merged
  const double inv_vs = 1.0 / tsdf.voxel_size_m;

  // 1. Classify points chunk by chunk; in merged mode collapse runs of points that end in the same
  //    voxel (neighbouring pixels mostly do) into partial sums.
  std::vector<ChunkResult> results(chunks);
  std::vector<RayBundle> per_ray;
  std::vector<char> valid;
  if (!merged) {
    per_ray.resize(points_S.size());
    valid.assign(points_S.size(), 0);
  }
  const PointClassifier classify(T_W_S, tsdf, integrator);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks), [&](const auto& r) {
    for (std::size_t c = r.begin(); c != r.end(); ++c) {
      ChunkResult& out = results[c];
      const std::size_t end = std::min(points_S.size(), (c + 1) * kPointChunk);
      Classified p;
      for (std::size_t i = c * kPointChunk; i < end; ++i) {
        if (!classify(points_S[i], out.stats, p)) continue;
        if (!merged) {
          per_ray[i] = RayBundle{p.end_W, p.weight_q, p.surface};
          valid[i] = 1;
          continue;
        }
        // The voxel of the end point: voxel i spans [i - 0.5, i + 0.5) * voxel_size.
        const openvdb::Coord voxel(fastFloor(p.end_W.x() * inv_vs + 0.5), fastFloor(p.end_W.y() * inv_vs + 0.5),
                                   fastFloor(p.end_W.z() * inv_vs + 0.5));
        const std::uint64_t key = packKey(voxel, p.surface);
        if (out.runs.empty() || out.runs.back().key != key) {
          out.runs.emplace_back();
          out.runs.back().key = key;
          out.runs.back().surface = p.surface;
        }
        BundleSum& run = out.runs.back();
        run.x_um += roundToInt64(p.end_W.x() * kMicrometresPerMetre);
        run.y_um += roundToInt64(p.end_W.y() * kMicrometresPerMetre);
        run.z_um += roundToInt64(p.end_W.z() * kMicrometresPerMetre);
        run.count += 1;
        run.weight_q += p.weight_q;
      }
    }
  });
  for (const ChunkResult& r : results) {
    stats.points_invalid += r.stats.points_invalid;
    stats.points_beyond_range += r.stats.points_beyond_range;
  }

  std::vector<RayBundle> bundles;
  if (!merged) {
    bundles.reserve(points_S.size());
    for (std::size_t i = 0; i < per_ray.size(); ++i)
      if (valid[i]) bundles.push_back(per_ray[i]);
    stats.rays_cast += bundles.size();
    return bundles;
  }

  // 2. Merge the runs by key (in order of first appearance, so the result does not depend on the
  //    chunking: integer sums), then order the bundles by direction for cache-friendly casting.
  std::size_t runs = 0;
  for (const ChunkResult& r : results) runs += r.runs.size();
  KeyIndex index(runs / 2);
  std::vector<BundleSum> sums;
  sums.reserve(runs / 2);
  for (const ChunkResult& r : results) {
    for (const BundleSum& run : r.runs) {
      bool inserted = false;
      const std::uint32_t i = index.findOrInsert(run.key, inserted);
      if (inserted)
        sums.push_back(run);
      else
        sums[i].add(run);
    }
  }
  bundles.reserve(sums.size());
  for (const BundleSum& b : sums) {
    const double inv = 1.0 / (double(b.count) * kMicrometresPerMetre);
    bundles.push_back(RayBundle{Vec3d(double(b.x_um) * inv, double(b.y_um) * inv, double(b.z_um) * inv), b.weight_q,
                                b.surface});
  }
  sortByDirection(bundles, T_W_S.translation(), tsdf.voxel_size_m);
  stats.rays_cast += bundles.size();
  return bundles;
}

void castRays(const std::vector<RayBundle>& bundles, const Vec3d& origin_W, const TsdfConfig& tsdf,
              openvdb::Int64Grid& weight_q, openvdb::Int64Grid& wsdf_q, std::int64_t sign, IntegrationStats& stats) {
  if (!bundles.empty()) {
    // The box around the rays' segments (origin to end, padded by the truncation band).
    const double pad = tsdf.truncation_m() + tsdf.voxel_size_m;
    Eigen::AlignedBox3d box(origin_W);
    for (const RayBundle& b : bundles) box.extend(b.end_W);
    const double inv = 1.0 / tsdf.voxel_size_m;
    const auto lo = ((box.min().array() - pad) * inv).floor().cast<int>();
    const auto hi = ((box.max().array() + pad) * inv).ceil().cast<int>();
    stats.touched_voxels.expand(openvdb::CoordBBox(openvdb::Coord(lo[0], lo[1], lo[2]), openvdb::Coord(hi[0], hi[1], hi[2])));
  }
  tbb::enumerable_thread_specific<BlockAccumulator> locals;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, bundles.size(), 64), [&](const auto& r) {
    BlockAccumulator& acc = locals.local();
    for (std::size_t i = r.begin(); i != r.end(); ++i) castOne(bundles[i], origin_W, tsdf, acc);
  });
  std::vector<Block*> blocks;
  for (const BlockAccumulator& acc : locals) {
    stats.voxel_updates += acc.updates;
    for (const auto& b : acc.blocks) blocks.push_back(b.get());
  }
  applyBlocks(blocks, weight_q.tree(), wsdf_q.tree(), sign);
  for (BlockAccumulator& acc : locals) releaseBlocks(acc.blocks);
}

}  // namespace vdbmap::internal
