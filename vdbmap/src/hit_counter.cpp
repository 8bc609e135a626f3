#include "internal/hit_counter.hpp"

#include <openvdb/tools/Prune.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <cmath>
#include <vector>

namespace vdbmap::internal {
namespace {

/// Points are keyed in fixed chunks, so the work does not depend on how TBB splits it.
constexpr std::size_t kPointChunk = 4096;
constexpr std::uint64_t kNoKey = ~std::uint64_t(0);

/// 21 bits per axis, offset so that negative coordinates sort correctly; coordinates wrap beyond
/// +-2^20 voxels (100 km at 0.1 m), as in the ray integrator.
inline std::uint64_t packVoxel(const openvdb::Coord& c) {
  constexpr std::int64_t bias = std::int64_t(1) << 20;
  constexpr std::uint64_t mask = (std::uint64_t(1) << 21) - 1;
  return ((std::uint64_t(c.x() + bias) & mask) << 42) | ((std::uint64_t(c.y() + bias) & mask) << 21) |
         (std::uint64_t(c.z() + bias) & mask);
}
inline openvdb::Coord unpackVoxel(std::uint64_t k) {
  constexpr std::int64_t bias = std::int64_t(1) << 20;
  constexpr std::uint64_t mask = (std::uint64_t(1) << 21) - 1;
  return openvdb::Coord(int(std::int64_t((k >> 42) & mask) - bias), int(std::int64_t((k >> 21) & mask) - bias),
                        int(std::int64_t(k & mask) - bias));
}

}  // namespace

void countHits(const PointCloud& points_S, const Pose3d& T_W_S, const TsdfConfig& tsdf,
               const IntegratorConfig& integrator, openvdb::Int64Grid& hits, std::int64_t sign) {
  const Eigen::Matrix3d R = T_W_S.linear();
  const Vec3d t = T_W_S.translation();
  const double min2 = integrator.min_range_m * integrator.min_range_m;
  const double max2 = integrator.max_range_m * integrator.max_range_m;
  const double inv_voxel = 1.0 / tsdf.voxel_size_m;

  // The voxel of every surface end point (kNoKey for the others), in point order.
  std::vector<std::uint64_t> keys(points_S.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points_S.size(), kPointChunk), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const Vec3f& p = points_S[i];
      const double r2 = p.cast<double>().squaredNorm();
      if (!p.allFinite() || !(r2 > 0.0) || r2 < min2 || r2 > max2) {
        keys[i] = kNoKey;
        continue;
      }
      const Vec3d e = (R * p.cast<double>() + t) * inv_voxel;  // voxel centres at integer coordinates
      keys[i] = packVoxel(openvdb::Coord(int(std::floor(e.x() + 0.5)), int(std::floor(e.y() + 0.5)),
                                         int(std::floor(e.z() + 0.5))));
    }
  });
  tbb::parallel_sort(keys.begin(), keys.end());

  // Serial: few distinct voxels (the surface a frame sees), and OpenVDB trees are not thread-safe
  // for writes.
  openvdb::Int64Grid::Accessor acc = hits.getAccessor();
  bool removed = false;
  for (std::size_t i = 0; i < keys.size() && keys[i] != kNoKey;) {
    std::size_t j = i + 1;
    while (j < keys.size() && keys[j] == keys[i]) ++j;
    const openvdb::Coord c = unpackVoxel(keys[i]);
    const std::int64_t n = acc.getValue(c) + sign * std::int64_t(j - i);
    if (n == 0) {
      acc.setValueOff(c, 0);
      removed = true;
    } else {
      acc.setValueOn(c, n);
    }
    i = j;
  }
  if (removed) openvdb::tools::pruneInactive(hits.tree());
}

}  // namespace vdbmap::internal
