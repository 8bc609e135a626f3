// Counting depth end points per voxel (private to the library).
//
// A TSDF averages every ray through a voxel, so a structure thinner than a voxel (a shelf upright,
// a pole, a cable) is carved free by the rays that pass beside it. The end points that land on it
// are not lost in the count, though: TsdfVolume keeps, per voxel, how many valid surface end points
// of its integrated frames fell in it. Counts are integers, so de-integration is exact like the sums.
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/config.hpp"
#include "vdbmap/openvdb.hpp"
#include "vdbmap/types.hpp"

namespace vdbmap::internal {

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

/// countHits and moveHits of backProject(depth_m, K) without making the cloud: each pixel's point
/// comes from backProjectPixel, so the counts are the same. depth_m must match K's size.
void countHits(const DepthImage& depth_m, const CameraIntrinsics& K, const Pose3d& T_W_S, const TsdfConfig& tsdf,
               const IntegratorConfig& integrator, openvdb::Int64Grid& hits, std::int64_t sign);
void moveHits(const DepthImage& depth_m, const CameraIntrinsics& K, const Pose3d& T_W_S_old, const Pose3d& T_W_S_new,
              const TsdfConfig& tsdf, const IntegratorConfig& integrator, openvdb::Int64Grid& hits);

}  // namespace vdbmap::internal
