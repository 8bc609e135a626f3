#include "internal/hit_counter.hpp"

#include <openvdb/tools/Prune.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
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

/// Which sensor-frame points are surface end points, and the voxel each ends in from one pose.
/// Every count goes through here, so that a count removed at a pose is the one added there.
class EndVoxels {
 public:
  EndVoxels(const TsdfConfig& tsdf, const IntegratorConfig& integrator)
      : min2_(integrator.min_range_m * integrator.min_range_m),
        max2_(integrator.max_range_m * integrator.max_range_m),
        inv_voxel_(1.0 / tsdf.voxel_size_m) {}

  /// Finite, and within [min_range_m, max_range_m] of the sensor: the points the integrators add
  /// as surface.
  bool isSurface(const Vec3d& p_S) const {
    const double r2 = p_S.squaredNorm();
    return p_S.allFinite() && r2 > 0.0 && r2 >= min2_ && r2 <= max2_;
  }
  /// The key of the voxel holding p_S seen from (R, t); voxel centres at integer coordinates.
  std::uint64_t key(const Vec3d& p_S, const Eigen::Matrix3d& R, const Vec3d& t) const {
    const Vec3d e = (R * p_S + t) * inv_voxel_;
    return packVoxel(openvdb::Coord(fastFloor(e.x() + 0.5), fastFloor(e.y() + 0.5), fastFloor(e.z() + 0.5)));
  }

 private:
  double min2_, max2_, inv_voxel_;
};

/// Consecutive end points in the same voxel, with their summed signed count: neighbouring pixels
/// mostly share a voxel, so the runs are about ten times fewer than the points.
struct Run {
  std::uint64_t key;
  std::int64_t count;
};
inline void append(std::vector<Run>& runs, std::uint64_t key, std::int64_t count) {
  if (!runs.empty() && runs.back().key == key)
    runs.back().count += count;
  else
    runs.push_back({key, count});
}

/// Calls fill(begin, end, runs) for fixed chunks of [0, n) in parallel and returns all runs, in
/// chunk order, so that the work does not depend on how TBB splits it.
template <typename Fill>
std::vector<Run> chunkRuns(std::size_t n, Fill&& fill) {
  const std::size_t chunks = (n + kPointChunk - 1) / kPointChunk;
  std::vector<std::vector<Run>> chunk_runs(chunks);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks), [&](const auto& r) {
    for (std::size_t c = r.begin(); c != r.end(); ++c)
      fill(c * kPointChunk, std::min(n, (c + 1) * kPointChunk), chunk_runs[c]);
  });
  std::vector<Run> runs;
  for (const std::vector<Run>& c : chunk_runs) runs.insert(runs.end(), c.begin(), c.end());
  return runs;
}

/// Adds each voxel's summed count to the grid; voxels whose count returns to 0 are removed.
void applyRuns(std::vector<Run>& runs, openvdb::Int64Grid& hits) {
  tbb::parallel_sort(runs.begin(), runs.end(), [](const Run& a, const Run& b) { return a.key < b.key; });
  // Serial: few distinct voxels (the surface a frame sees), and OpenVDB trees are not thread-safe
  // for writes.
  openvdb::Int64Grid::Accessor acc = hits.getAccessor();
  bool removed = false;
  for (std::size_t i = 0; i < runs.size();) {
    std::int64_t count = 0;
    std::size_t j = i;
    for (; j < runs.size() && runs[j].key == runs[i].key; ++j) count += runs[j].count;
    const std::uint64_t key = runs[i].key;
    i = j;
    if (count == 0) continue;  // moved out and back in: unchanged
    const openvdb::Coord c = unpackVoxel(key);
    const std::int64_t n = acc.getValue(c) + count;
    if (n == 0) {
      acc.setValueOff(c, 0);
      removed = true;
    } else {
      acc.setValueOn(c, n);
    }
  }
  if (removed) openvdb::tools::pruneInactive(hits.tree());
}

/// The points of a cloud, for the counting loops.
class CloudPoints {
 public:
  explicit CloudPoints(const PointCloud& points_S) : points_(points_S) {}
  std::size_t size() const { return points_.size(); }
  /// Calls visit(p_S) for the points [begin, end), in order.
  template <typename Visit>
  void forRange(std::size_t begin, std::size_t end, Visit&& visit) const {
    for (std::size_t i = begin; i < end; ++i) visit(Vec3d(points_[i].cast<double>()));
  }

 private:
  const PointCloud& points_;
};

/// The points backProject() would make of an image, without making them: pixel i in row-major
/// order is point i; invalid pixels (NaN points there) are skipped.
class ImagePoints {
 public:
  ImagePoints(const DepthImage& depth_m, const CameraIntrinsics& K)
      : depth_(depth_m), K_(K), inv_fx_(1.0 / K.fx), inv_fy_(1.0 / K.fy) {
    if (depth_m.width != K.width || depth_m.height != K.height ||
        depth_m.depth_m.size() != std::size_t(K.width) * std::size_t(K.height))
      throw std::invalid_argument("countHits: the depth image's size differs from the camera's");
  }
  std::size_t size() const { return depth_.depth_m.size(); }
  template <typename Visit>
  void forRange(std::size_t begin, std::size_t end, Visit&& visit) const {
    const std::size_t w = std::size_t(depth_.width);
    int u = int(begin % w), v = int(begin / w);
    for (std::size_t i = begin; i < end; ++i) {
      const float z = depth_.depth_m[i];
      if (z > 0.0f && std::isfinite(z)) visit(Vec3d(backProjectPixel(u, v, z, K_, inv_fx_, inv_fy_).cast<double>()));
      if (++u == depth_.width) {
        u = 0;
        ++v;
      }
    }
  }

 private:
  const DepthImage& depth_;
  const CameraIntrinsics& K_;
  double inv_fx_, inv_fy_;
};

template <typename Points>
void countHitsOf(const Points& points, const Pose3d& T_W_S, const TsdfConfig& tsdf, const IntegratorConfig& integrator,
                 openvdb::Int64Grid& hits, std::int64_t sign) {
  const EndVoxels ends(tsdf, integrator);
  const Eigen::Matrix3d R = T_W_S.linear();
  const Vec3d t = T_W_S.translation();
  std::vector<Run> runs = chunkRuns(points.size(), [&](std::size_t begin, std::size_t end, std::vector<Run>& out) {
    points.forRange(begin, end, [&](const Vec3d& p) {
      if (ends.isSurface(p)) append(out, ends.key(p, R, t), sign);
    });
  });
  applyRuns(runs, hits);
}

template <typename Points>
void moveHitsOf(const Points& points, const Pose3d& T_W_S_old, const Pose3d& T_W_S_new, const TsdfConfig& tsdf,
                const IntegratorConfig& integrator, openvdb::Int64Grid& hits) {
  const EndVoxels ends(tsdf, integrator);
  const Eigen::Matrix3d R_old = T_W_S_old.linear(), R_new = T_W_S_new.linear();
  const Vec3d t_old = T_W_S_old.translation(), t_new = T_W_S_new.translation();
  std::vector<Run> runs = chunkRuns(points.size(), [&](std::size_t begin, std::size_t end, std::vector<Run>& out) {
    std::vector<Run> added;  // kept apart from the removals, so that each side stays run-length coded
    points.forRange(begin, end, [&](const Vec3d& p) {
      if (!ends.isSurface(p)) return;
      const std::uint64_t from = ends.key(p, R_old, t_old), to = ends.key(p, R_new, t_new);
      if (from == to) return;
      append(out, from, -1);
      append(added, to, +1);
    });
    out.insert(out.end(), added.begin(), added.end());
  });
  applyRuns(runs, hits);
}

}  // namespace

void countHits(const PointCloud& points_S, const Pose3d& T_W_S, const TsdfConfig& tsdf,
               const IntegratorConfig& integrator, openvdb::Int64Grid& hits, std::int64_t sign) {
  countHitsOf(CloudPoints(points_S), T_W_S, tsdf, integrator, hits, sign);
}

void moveHits(const PointCloud& points_S, const Pose3d& T_W_S_old, const Pose3d& T_W_S_new, const TsdfConfig& tsdf,
              const IntegratorConfig& integrator, openvdb::Int64Grid& hits) {
  moveHitsOf(CloudPoints(points_S), T_W_S_old, T_W_S_new, tsdf, integrator, hits);
}

void countHits(const DepthImage& depth_m, const CameraIntrinsics& K, const Pose3d& T_W_S, const TsdfConfig& tsdf,
               const IntegratorConfig& integrator, openvdb::Int64Grid& hits, std::int64_t sign) {
  countHitsOf(ImagePoints(depth_m, K), T_W_S, tsdf, integrator, hits, sign);
}

void moveHits(const DepthImage& depth_m, const CameraIntrinsics& K, const Pose3d& T_W_S_old, const Pose3d& T_W_S_new,
              const TsdfConfig& tsdf, const IntegratorConfig& integrator, openvdb::Int64Grid& hits) {
  moveHitsOf(ImagePoints(depth_m, K), T_W_S_old, T_W_S_new, tsdf, integrator, hits);
}

}  // namespace vdbmap::internal
