// Turning one frame's points into exact fixed-point voxel updates (private to the library).
//
// Step 1 (bundleRays): every valid point becomes a ray from the sensor origin; in Merged mode the
// points whose end falls in the same voxel are bundled into one ray to their mean end point, with
// the sum of their weights. Sums are kept in integers (positions in micrometres), so the bundles do
// not depend on the order in which threads meet the points.
// Step 2 (castRays): each bundle walks its voxels with a 3D DDA and adds integer (W, WD) updates
// into per-thread grids, which are then added into the map leaf by leaf (addTrees). Integer
// addition makes the result independent of thread count and order.
#pragma once

#include "vdbmap/config.hpp"
#include "vdbmap/openvdb.hpp"
#include "vdbmap/tsdf_volume.hpp"
#include "vdbmap/types.hpp"

#include <vector>

namespace vdbmap::internal {

struct RayBundle {
  Vec3d end_W;               ///< where the ray ends (the surface, or max range for carve-only rays)
  std::int64_t weight_q = 0; ///< summed fixed-point weight of the bundled points
  bool surface = true;       ///< false: the point was beyond max range; carve free space only
};

std::vector<RayBundle> bundleRays(const PointCloud& points_S, const Pose3d& T_W_S, const TsdfConfig& tsdf,
                                  const IntegratorConfig& integrator, IntegrationStats& stats);

/// Adds sign * (the bundles' updates) into W and WD, in parallel. Voxels whose weight returns to 0
/// are removed when sign < 0.
void castRays(const std::vector<RayBundle>& bundles, const Vec3d& origin_W, const TsdfConfig& tsdf,
              openvdb::Int64Grid& weight_q, openvdb::Int64Grid& wsdf_q, std::int64_t sign, IntegrationStats& stats);

}  // namespace vdbmap::internal
