// Counting depth end points per voxel (private to the library).
//
// A TSDF averages every ray through a voxel, so a structure thinner than a voxel (a shelf upright,
// a pole, a cable) is carved free by the rays that pass beside it. The end points that land on it
// are not lost in the count, though: TsdfVolume keeps, per voxel, how many valid surface end points
// of its integrated frames fell in it. Counts are integers, so de-integration is exact like the sums.
//
// Clouds are counted here; depth images are counted by the projective integrator in its pass over
// the pixels, with the same EndVoxels, so both give every point the same voxel.
#pragma once

#include "internal/simd.hpp"
#include "internal/voxel_blocks.hpp"

#include "vdbmap/camera.hpp"
#include "vdbmap/config.hpp"
#include "vdbmap/openvdb.hpp"
#include "vdbmap/types.hpp"

#include <cstdint>
#include <vector>

namespace vdbmap::internal {

/// A voxel coordinate packed into 64 bits: 21 bits per axis, offset so that negative coordinates
/// sort correctly; coordinates wrap beyond +-2^20 voxels (100 km at 0.1 m), as in the ray
/// integrator.
inline std::uint64_t packVoxel(const openvdb::Coord& c) {
  constexpr std::int64_t bias = std::int64_t(1) << 20;
  constexpr std::uint64_t mask = (std::uint64_t(1) << 21) - 1;
  return ((std::uint64_t(c.x() + bias) & mask) << 42) | ((std::uint64_t(c.y() + bias) & mask) << 21) |
         (std::uint64_t(c.z() + bias) & mask);
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
    const double r2 = (p_S.x() * p_S.x() + p_S.y() * p_S.y()) + p_S.z() * p_S.z();
    return p_S.allFinite() && r2 > 0.0 && r2 >= min2_ && r2 <= max2_;
  }
  /// The key of the voxel holding p_S seen from (R, t); voxel centres at integer coordinates.
  /// Summed in a fixed order, which countRowHits() repeats two points at a time: rows 0 and 1 as
  /// ((R_i0 x + R_i1 y) + R_i2 z) + t_i, row 2 as (R_20 x + (R_21 y + R_22 z)) + t_2. This is the
  /// order in which Eigen's SSE2 product summed R * p + t for the maps saved before, so their
  /// counts stay exact.
  std::uint64_t key(const Vec3d& p, const Eigen::Matrix3d& R, const Vec3d& t) const {
    const double ex = (((R(0, 0) * p.x() + R(0, 1) * p.y()) + R(0, 2) * p.z()) + t.x()) * inv_voxel_;
    const double ey = (((R(1, 0) * p.x() + R(1, 1) * p.y()) + R(1, 2) * p.z()) + t.y()) * inv_voxel_;
    const double ez = ((R(2, 0) * p.x() + (R(2, 1) * p.y() + R(2, 2) * p.z())) + t.z()) * inv_voxel_;
    return packVoxel(openvdb::Coord(fastFloor(ex + 0.5), fastFloor(ey + 0.5), fastFloor(ez + 0.5)));
  }
  double minRange2() const { return min2_; }
  double maxRange2() const { return max2_; }
  double inverseVoxelSize() const { return inv_voxel_; }

 private:
  double min2_, max2_, inv_voxel_;
};

/// Consecutive end points in the same voxel, with their summed signed count: neighbouring pixels
/// mostly share a voxel, so the runs are about ten times fewer than the points.
struct HitRun {
  std::uint64_t key;
  std::int64_t count;
};
inline void appendHit(std::vector<HitRun>& runs, std::uint64_t key, std::int64_t count) {
  if (!runs.empty() && runs.back().key == key)
    runs.back().count += count;
  else
    runs.push_back({key, count});
}

/// Merges each voxel's runs into one, in the order of their first run, dropping those that sum to
/// 0. A chunk of image rows meets most of its voxels in several rows, so compacting each chunk
/// where it was counted leaves applyHitRuns a few times fewer runs.
void compactHitRuns(std::vector<HitRun>& runs);

/// One placement of end points for counting: seen from (R, t), each counts `sign`.
struct HitPose {
  Eigen::Matrix3d R;
  Vec3d t;
  std::int64_t sign = 1;
};

/// Counts the surface end points of row v of a depth image (the points backProject() makes of its
/// pixels, left to right) from every pose into runs[j], with the same result as countHits() on
/// them, one, two or four pixels at a time as `level` says (every level gives the same runs).
/// With two poses of opposite signs (a move), the points that end in the same voxel at both are
/// skipped. depth_m must match K's size.
void countRowHits(const DepthImage& depth_m, int v, const CameraIntrinsics& K, const EndVoxels& ends,
                  const std::vector<HitPose>& poses, std::vector<HitRun>* runs, SimdLevel level = simdLevel());

/// Adds each voxel's summed count to the grid; voxels whose count returns to 0 are removed. The
/// result depends only on the sums, not on the order of the runs. Leaf by leaf in parallel; only
/// creating leaves is serial.
void applyHitRuns(const std::vector<HitRun>& runs, openvdb::Int64Grid& hits);

/// Adds `sign` to the count of the voxel holding each surface end point of `points_S` seen from
/// T_W_S: points that are finite, at least min_range_m and at most max_range_m from the sensor (the
/// points the integrators add as surface). Voxels whose count returns to 0 are removed.
void countHits(const PointCloud& points_S, const Pose3d& T_W_S, const TsdfConfig& tsdf,
               const IntegratorConfig& integrator, openvdb::Int64Grid& hits, std::int64_t sign);

/// Moves the counts of points_S from T_W_S_old to T_W_S_new: every voxel ends as after countHits
/// at the old pose with sign -1 then at the new pose with sign +1, but in one pass that skips the
/// points that stay in their voxel (most of them, for the corrections of a loop closure).
void moveHits(const PointCloud& points_S, const Pose3d& T_W_S_old, const Pose3d& T_W_S_new, const TsdfConfig& tsdf,
              const IntegratorConfig& integrator, openvdb::Int64Grid& hits);

}  // namespace vdbmap::internal
