#include "internal/ray_integrator.hpp"

#include <openvdb/tools/Prune.h>
#include <openvdb/tree/LeafManager.h>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>
#include <unordered_map>

namespace vdbmap::internal {
namespace {

using Int64Tree = openvdb::Int64Tree;
using Int64Leaf = Int64Tree::LeafNodeType;

constexpr double kMicrometresPerMetre = 1e6;
constexpr std::int64_t kFractionScale = 1 << 16;  // fixed point of the behind-surface drop-off

/// Voxel of a world point: voxel i spans [i - 0.5, i + 0.5) * voxel_size (OpenVDB's centres).
inline openvdb::Coord voxelOf(const Vec3d& p_W, double inv_voxel) {
  return openvdb::Coord(int(std::floor(p_W.x() * inv_voxel + 0.5)), int(std::floor(p_W.y() * inv_voxel + 0.5)),
                        int(std::floor(p_W.z() * inv_voxel + 0.5)));
}

inline std::uint64_t packKey(const openvdb::Coord& c, bool surface) {
  constexpr std::uint64_t mask = (1u << 21) - 1;
  return (std::uint64_t(surface) << 63) | ((std::uint64_t(c.x()) & mask) << 42) |
         ((std::uint64_t(c.y()) & mask) << 21) | (std::uint64_t(c.z()) & mask);
}

struct BundleSum {
  std::int64_t x_um = 0, y_um = 0, z_um = 0;  // summed end points in micrometres
  std::int64_t count = 0;
  std::int64_t weight_q = 0;
  bool surface = true;
};

struct KeyHash {
  std::size_t operator()(std::uint64_t k) const { return std::size_t((k ^ (k >> 29)) * 0xbf58476d1ce4e5b9ULL); }
};
using BundleMap = std::unordered_map<std::uint64_t, BundleSum, KeyHash>;

/// A point's ray weight in fixed point; z is its depth along the optical axis.
inline std::int64_t pointWeight(const TsdfConfig& tsdf, double z) {
  if (tsdf.weighting == Weighting::Constant) return kWeightScale;
  return std::llround(double(kWeightScale) / (z * z));
}

struct Classified {
  Vec3d end_W;
  std::int64_t weight_q;
  bool surface;
};

/// Classifies one point; returns false (and counts it) when it is invalid.
inline bool classify(const Vec3f& p, const Pose3d& T_W_S, const TsdfConfig& tsdf, const IntegratorConfig& in,
                     IntegrationStats& stats, Classified& out) {
  if (!p.allFinite()) {
    ++stats.points_invalid;
    return false;
  }
  const Vec3d p_S = p.cast<double>();
  const double range = p_S.norm();
  if (!(range > 0.0) || range < in.min_range_m) {
    ++stats.points_invalid;
    return false;
  }
  const double z = p_S.z() > 0.0 ? p_S.z() : range;
  if (range > in.max_range_m) {
    ++stats.points_beyond_range;
    const double s = in.max_range_m / range;
    out.end_W = T_W_S * (p_S * s);
    out.weight_q = pointWeight(tsdf, z * s);
    out.surface = false;
    return true;
  }
  out.end_W = T_W_S * p_S;
  out.weight_q = pointWeight(tsdf, z);
  out.surface = true;
  return true;
}

void addStats(IntegrationStats& into, const IntegrationStats& s) {
  into.points_invalid += s.points_invalid;
  into.points_beyond_range += s.points_beyond_range;
  into.voxel_updates += s.voxel_updates;
}

/// Per-thread accumulation grids with a one-leaf cache (consecutive DDA voxels share leaves).
struct LocalGrids {
  Int64Tree weight{0}, wsdf{0};
  openvdb::tree::ValueAccessor<Int64Tree> weight_acc{weight}, wsdf_acc{wsdf};
  Int64Leaf* weight_leaf = nullptr;
  Int64Leaf* wsdf_leaf = nullptr;
  std::int64_t* weight_data = nullptr;  // the leaves' in-core buffers: no per-value checks
  std::int64_t* wsdf_data = nullptr;
  openvdb::Coord leaf_origin{std::numeric_limits<int>::max()};
  std::size_t updates = 0;

  void add(const openvdb::Coord& ijk, std::int64_t dw, std::int64_t dwd) {
    const openvdb::Coord origin = ijk & ~(Int64Leaf::DIM - 1);
    if (origin != leaf_origin) {
      weight_leaf = weight_acc.touchLeaf(ijk);
      wsdf_leaf = wsdf_acc.touchLeaf(ijk);
      weight_data = weight_leaf->buffer().data();
      wsdf_data = wsdf_leaf->buffer().data();
      leaf_origin = origin;
    }
    const openvdb::Index n = Int64Leaf::coordToOffset(ijk);
    weight_data[n] += dw;
    wsdf_data[n] += dwd;
    weight_leaf->setActiveState(n, true);
    wsdf_leaf->setActiveState(n, true);
    ++updates;
  }
};

/// Walks the voxels of one bundle with a 3D DDA (Amanatides & Woo) and adds its updates.
void castOne(const RayBundle& b, const Vec3d& origin_W, const TsdfConfig& tsdf, LocalGrids& out) {
  const double vs = tsdf.voxel_size_m, inv_vs = 1.0 / vs;
  const double delta = tsdf.truncation_m();
  const Vec3d d = b.end_W - origin_W;
  const double dist = d.norm();
  if (!(dist > 1e-9)) return;
  const Vec3d dir = d / dist;
  const double t_end = b.surface ? dist + delta : dist - delta;
  if (t_end <= 0.0) return;

  // Index space shifted by +0.5, where voxel i spans [i, i + 1).
  const Vec3d o = origin_W * inv_vs + Vec3d::Constant(0.5);
  int ijk[3], step[3];
  double t_max[3], t_delta[3];
  for (int a = 0; a < 3; ++a) {
    ijk[a] = int(std::floor(o[a]));
    const double g = dir[a] * inv_vs;  // index units per metre along the ray
    if (g > 0.0) {
      step[a] = 1;
      t_max[a] = (ijk[a] + 1 - o[a]) / g;
      t_delta[a] = 1.0 / g;
    } else if (g < 0.0) {
      step[a] = -1;
      t_max[a] = (ijk[a] - o[a]) / g;
      t_delta[a] = -1.0 / g;
    } else {
      step[a] = 0;
      t_max[a] = t_delta[a] = std::numeric_limits<double>::infinity();
    }
  }

  const bool drop_off = tsdf.weighting == Weighting::InverseSquare;
  const double epsilon = vs;
  const double inv_delta = 1.0 / delta;
  while (true) {
    const Vec3d centre(ijk[0] * vs, ijk[1] * vs, ijk[2] * vs);
    double sdf = b.surface ? dist - (centre - origin_W).dot(dir) : delta;
    if (sdf >= -delta) {
      if (sdf > delta) sdf = delta;
      std::int64_t w = b.weight_q;
      if (drop_off && b.surface && sdf < -epsilon) {
        const double f = delta > epsilon ? (delta + sdf) / (delta - epsilon) : 0.0;
        w = (w * std::llround(f * kFractionScale)) / kFractionScale;
      }
      if (w > 0) {
        const std::int64_t dq = std::llround(sdf * inv_delta * double(kSdfScale));
        out.add(openvdb::Coord(ijk[0], ijk[1], ijk[2]), w, w * dq);
      }
    }
    const int a = t_max[0] < t_max[1] ? (t_max[0] < t_max[2] ? 0 : 2) : (t_max[1] < t_max[2] ? 1 : 2);
    if (t_max[a] > t_end) break;
    ijk[a] += step[a];
    t_max[a] += t_delta[a];
  }
}

/// dst += sign * src over src's active voxels, then (sign < 0) drops voxels whose weight is 0.
void addTrees(Int64Tree& dst_w, Int64Tree& dst_wd, const Int64Tree& src_w, const Int64Tree& src_wd, std::int64_t sign) {
  dst_w.topologyUnion(src_w);
  dst_wd.topologyUnion(src_wd);
  std::vector<const Int64Leaf*> leaves;
  leaves.reserve(src_w.leafCount());
  for (auto it = src_w.cbeginLeaf(); it; ++it) leaves.push_back(it.getLeaf());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size(), 64), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const Int64Leaf& sw = *leaves[i];
      const Int64Leaf* swd = src_wd.probeConstLeaf(sw.origin());
      Int64Leaf* dw = dst_w.probeLeaf(sw.origin());
      Int64Leaf* dwd = dst_wd.probeLeaf(sw.origin());
      for (auto v = sw.cbeginValueOn(); v; ++v) {
        const openvdb::Index n = v.pos();
        const std::int64_t w = dw->getValue(n) + sign * *v;
        const std::int64_t wd = dwd->getValue(n) + sign * swd->getValue(n);
        if (w == 0) {  // every contribution to this voxel is gone: remove it
          dw->setValueOff(n, 0);
          dwd->setValueOff(n, 0);
        } else {
          dw->setValueOn(n, w);
          dwd->setValueOn(n, wd);
        }
      }
    }
  });
  if (sign < 0) {
    openvdb::tools::pruneInactive(dst_w);
    openvdb::tools::pruneInactive(dst_wd);
  }
}

}  // namespace

std::vector<RayBundle> bundleRays(const PointCloud& points_S, const Pose3d& T_W_S, const TsdfConfig& tsdf,
                                  const IntegratorConfig& integrator, IntegrationStats& stats) {
  stats.points_total += points_S.size();
  const std::size_t grain = 4096;
  std::vector<RayBundle> bundles;

  if (integrator.ray_mode == RayMode::PerRay) {
    std::vector<RayBundle> all(points_S.size());
    std::vector<char> valid(points_S.size(), 0);
    tbb::enumerable_thread_specific<IntegrationStats> local_stats;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points_S.size(), grain), [&](const auto& r) {
      IntegrationStats& s = local_stats.local();
      Classified c;
      for (std::size_t i = r.begin(); i != r.end(); ++i) {
        if (!classify(points_S[i], T_W_S, tsdf, integrator, s, c)) continue;
        all[i] = RayBundle{c.end_W, c.weight_q, c.surface};
        valid[i] = 1;
      }
    });
    for (const auto& s : local_stats) addStats(stats, s);
    bundles.reserve(points_S.size());
    for (std::size_t i = 0; i < all.size(); ++i)
      if (valid[i]) bundles.push_back(all[i]);
    stats.rays_cast += bundles.size();
    return bundles;
  }

  const double inv_vs = 1.0 / tsdf.voxel_size_m;
  tbb::enumerable_thread_specific<BundleMap> local_maps;
  tbb::enumerable_thread_specific<IntegrationStats> local_stats;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points_S.size(), grain), [&](const auto& r) {
    BundleMap& map = local_maps.local();
    IntegrationStats& s = local_stats.local();
    std::uint64_t last_key = 0;
    BundleSum* last = nullptr;  // neighbouring pixels mostly end in the same voxel
    Classified c;
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      if (!classify(points_S[i], T_W_S, tsdf, integrator, s, c)) continue;
      const std::uint64_t key = packKey(voxelOf(c.end_W, inv_vs), c.surface);
      if (!last || key != last_key) {
        last = &map[key];
        last_key = key;
        last->surface = c.surface;
      }
      last->x_um += std::llround(c.end_W.x() * kMicrometresPerMetre);
      last->y_um += std::llround(c.end_W.y() * kMicrometresPerMetre);
      last->z_um += std::llround(c.end_W.z() * kMicrometresPerMetre);
      last->count += 1;
      last->weight_q += c.weight_q;
    }
  });
  for (const auto& s : local_stats) addStats(stats, s);

  BundleMap merged;
  for (auto& map : local_maps) {
    if (merged.empty()) {
      merged.swap(map);
      continue;
    }
    for (const auto& [key, b] : map) {
      BundleSum& m = merged[key];
      m.x_um += b.x_um;
      m.y_um += b.y_um;
      m.z_um += b.z_um;
      m.count += b.count;
      m.weight_q += b.weight_q;
      m.surface = b.surface;
    }
  }
  bundles.reserve(merged.size());
  for (const auto& [key, b] : merged) {
    const double inv = 1.0 / (double(b.count) * kMicrometresPerMetre);
    bundles.push_back(RayBundle{Vec3d(double(b.x_um) * inv, double(b.y_um) * inv, double(b.z_um) * inv), b.weight_q,
                                b.surface});
  }
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
  tbb::enumerable_thread_specific<LocalGrids> locals;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, bundles.size(), 256), [&](const auto& r) {
    LocalGrids& g = locals.local();
    for (std::size_t i = r.begin(); i != r.end(); ++i) castOne(bundles[i], origin_W, tsdf, g);
  });
  for (LocalGrids& g : locals) {
    stats.voxel_updates += g.updates;
    addTrees(weight_q.tree(), wsdf_q.tree(), g.weight, g.wsdf, sign);
  }
}

}  // namespace vdbmap::internal
