// Projective integration of a depth image (private to the library): voxel by voxel instead of
// ray by ray, as KinectFusion, Open3D and nvblox do.
//
// Every voxel of the camera frustum is projected into the image; the pixel it falls in (nearest
// pixel centre) gives the range R of the surface along that pixel's ray, and the voxel gets the
// update of a ray of that pixel's weight at signed distance sdf = R - |CV| (C the camera centre,
// V the voxel centre): the same value the ray integrator gives the voxels along a ray (DESIGN
// section 4), but each voxel is updated once per frame instead of once per ray that crosses it,
// so the cost grows with the frustum's volume, not with the rays' summed lengths. Pixels beyond
// max range carve free space up to it and add no surface; invalid pixels add nothing.
//
// Candidate voxels are whole leaves (8^3): the leaves that coarse rays through tiles of the image
// cross (each tile's ray going as far as the tile's farthest valid pixel + truncation), dilated by
// one leaf so that no voxel of the frustum is missed, then culled against the frustum. Each leaf is
// computed by one task into its own block, and the blocks are applied exactly (integer sums), so
// the result is independent of thread count and integration then de-integration is the identity.
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/config.hpp"
#include "vdbmap/openvdb.hpp"
#include "vdbmap/tsdf_volume.hpp"
#include "vdbmap/types.hpp"
#include "vdbmap/voxel_footprint.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace vdbmap::internal {

/// One placement of the image: seen from T_W_S, added (sign +1) or removed (sign -1).
struct ImagePlacement {
  Pose3d T_W_S;
  std::int64_t sign = 1;
};

/// Adds the image's updates at every placement (each times its sign) into W and WD, in one pass:
/// a re-integration {(old pose, -1), (new pose, +1)} classifies the pixels once and applies only
/// the net change. Throws std::invalid_argument when the image size differs from the intrinsics.
/// `stats` counts the pixels once and the voxel updates of all placements. When `hits` is given,
/// the image's surface end points are counted into it at every placement (times its sign), in the
/// same pass over the pixels and with the same result as countHits() and moveHits() on
/// backProject(depth_m, K). When `footprint` is given it receives the voxels the added placements
/// (sign > 0) update, exactly as projectiveFootprint() finds them.
void integrateProjective(const DepthImage& depth_m, const CameraIntrinsics& K,
                         const std::vector<ImagePlacement>& placements, const TsdfConfig& tsdf,
                         const IntegratorConfig& integrator, openvdb::Int64Grid& weight_q, openvdb::Int64Grid& wsdf_q,
                         openvdb::Int64Grid* hits, IntegrationStats& stats, VoxelFootprint* footprint = nullptr);

/// The voxels integrateProjective would update for the image seen from T_W_S (free space and the
/// band around the surface; a band voxel whose weight drops to zero behind the surface counts as
/// updated), by the very same tests, without writing anything. Leaves with no such voxel are left
/// out. Throws std::invalid_argument when the image size differs from the intrinsics.
VoxelFootprint projectiveFootprint(const DepthImage& depth_m, const CameraIntrinsics& K, const Pose3d& T_W_S,
                                               const TsdfConfig& tsdf, const IntegratorConfig& integrator);

}  // namespace vdbmap::internal
