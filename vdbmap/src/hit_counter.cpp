#include "internal/hit_counter.hpp"

#include <openvdb/tools/Prune.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace vdbmap::internal {
namespace {

/// Points are run-length coded in fixed chunks, so the work does not depend on how TBB splits it.
constexpr std::size_t kPointChunk = 4096;

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

/// floor(x) as an int without the libm call; equal to int(std::floor(x)) for |x| < 2^31.
inline int fastFloor(double x) {
  const int i = int(x);
  return i - int(x < double(i));
}

}  // namespace

void countHits(const PointCloud& points_S, const Pose3d& T_W_S, const TsdfConfig& tsdf,
               const IntegratorConfig& integrator, openvdb::Int64Grid& hits, std::int64_t sign) {
  const Eigen::Matrix3d R = T_W_S.linear();
  const Vec3d t = T_W_S.translation();
  const double min2 = integrator.min_range_m * integrator.min_range_m;
  const double max2 = integrator.max_range_m * integrator.max_range_m;
  const double inv_voxel = 1.0 / tsdf.voxel_size_m;

  // Per chunk of points, the runs of consecutive end points in the same voxel: neighbouring pixels
  // mostly share a voxel, so the runs are about ten times fewer than the points.
  struct Run {
    std::uint64_t key;
    std::int64_t count;
  };
  const std::size_t chunks = (points_S.size() + kPointChunk - 1) / kPointChunk;
  std::vector<std::vector<Run>> chunk_runs(chunks);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks), [&](const auto& r) {
    for (std::size_t c = r.begin(); c != r.end(); ++c) {
      std::vector<Run>& runs = chunk_runs[c];
      const std::size_t end = std::min(points_S.size(), (c + 1) * kPointChunk);
      for (std::size_t i = c * kPointChunk; i < end; ++i) {
        const Vec3d p = points_S[i].cast<double>();
        const double r2 = p.squaredNorm();
        if (!p.allFinite() || !(r2 > 0.0) || r2 < min2 || r2 > max2) continue;
        const Vec3d e = (R * p + t) * inv_voxel;  // voxel centres at integer coordinates
        const std::uint64_t key =
            packVoxel(openvdb::Coord(fastFloor(e.x() + 0.5), fastFloor(e.y() + 0.5), fastFloor(e.z() + 0.5)));
        if (!runs.empty() && runs.back().key == key)
          ++runs.back().count;
        else
          runs.push_back({key, 1});
      }
    }
  });
  std::vector<Run> runs;
  for (const std::vector<Run>& c : chunk_runs) runs.insert(runs.end(), c.begin(), c.end());
  tbb::parallel_sort(runs.begin(), runs.end(), [](const Run& a, const Run& b) { return a.key < b.key; });

  // Serial: few distinct voxels (the surface a frame sees), and OpenVDB trees are not thread-safe
  // for writes.
  openvdb::Int64Grid::Accessor acc = hits.getAccessor();
  bool removed = false;
  for (std::size_t i = 0; i < runs.size();) {
    std::int64_t count = 0;
    std::size_t j = i;
    for (; j < runs.size() && runs[j].key == runs[i].key; ++j) count += runs[j].count;
    const openvdb::Coord c = unpackVoxel(runs[i].key);
    const std::int64_t n = acc.getValue(c) + sign * count;
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
