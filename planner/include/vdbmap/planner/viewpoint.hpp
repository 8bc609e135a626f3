// Viewpoints: where the vehicle should stand, and which way it should look, to observe a frontier
// cluster (FUEL, Zhou et al. 2021, Sect. IV-B).
//
// Candidates lie on horizontal rings around the cluster's centroid (FUEL: radii 1.5-2.5 m in four
// rings, 15 deg apart, at the centroid's height). A candidate is kept when it is clear (every
// voxel within min_clearance_m known-free: neither occupied nor unknown space nearby) and sees
// more than min_visible_samples of the cluster's sample voxels. Yaw points at the cluster: the
// circular mean of the horizontal directions to its samples. A sample is seen when it lies in
// the camera's frustum at that yaw (zero pitch) within range, and the ray from it to the
// viewpoint crosses only known-free voxels (occupied and unknown space both occlude).
//
// Beyond FUEL: a cluster that no ring candidate observes (a pocket between shelf boards, under a
// table, behind a post: the 1.5-2.5 m rings are blocked or see too little of it) gets a second,
// closer and taller search (ViewpointFallback). Without it such clusters have no viewpoint, are
// never targeted, and exploration finishes with their surfaces unknown.
#pragma once

#include "vdbmap/planner/frontier.hpp"
#include "vdbmap/planner/map_query.hpp"
#include "vdbmap/planner/vehicle_state.hpp"

#include <Eigen/Geometry>

#include <optional>
#include <vector>

namespace vdbmap::planner {

/// The depth camera as the planner models it: a frustum looking along the vehicle's yaw.
/// Defaults are FUEL's: a 640 x 480 image with fx = fy = 387.229 px, planning range 4.5 m
/// (FUEL's perception max_dist; the sensor itself reaches 5 m).
struct CameraFrustum {
  double tan_half_fov_x = 320.0 / 387.229;  ///< half image width / fx; (0, 100]
  double tan_half_fov_y = 240.0 / 387.229;  ///< half image height / fy; (0, 100]
  double min_range_m = 0.0;                 ///< [0, max_range_m)
  double max_range_m = 4.5;                 ///< (min_range_m, 1e3]

  /// True when p_W is inside the frustum of a camera at `eye_W` looking along `yaw_rad`.
  bool contains(const Vec3d& eye_W, double yaw_rad, const Vec3d& p_W) const;
  /// The point of p_W's vertical line nearest p_W that a level camera at `eye_W` sees (range
  /// aside) when it turns to face that line within yaw_tolerance_rad: p_W itself when it lies
  /// within that band; nullopt when p_W lies less than min_across_m from eye_W horizontally (or at
  /// no horizontal distance) and outside it. Turned off the line by an angle a, the camera sees it
  /// at depth cos(a) times the horizontal distance, so the band is cos(yaw_tolerance_rad) times the
  /// vertical half field of view's. Throws std::invalid_argument unless yaw_tolerance_rad lies in
  /// [0, pi/2) and within the horizontal half field of view.
  std::optional<Vec3d> nearestInViewOnVertical(const Vec3d& eye_W, const Vec3d& p_W, double min_across_m,
                                               double yaw_tolerance_rad = 0.0) const;
  void validate() const;
};

/// The second search for clusters with no ring viewpoint: more rings, from closer in, at several
/// heights, and a threshold that a small cluster can meet.
struct ViewpointFallback {
  bool enabled = true;
  double ring_radius_min_m = 0.5;  ///< (0, ring_radius_max_m]; keep above the camera's near limit
  double ring_radius_max_m = 2.5;  ///< [ring_radius_min_m, 100]
  int ring_count = 5;              ///< radii evenly spaced from min to max; [1, 100]
  /// Heights of the rings relative to the cluster's centroid; each in [-100, 100], non-empty.
  std::vector<double> height_offsets_m = {0.0, -0.5, 0.5, -1.0, 1.0};
  /// Every voxel within this distance of a fallback viewpoint is known-free; [0, 10]. Above
  /// ViewpointConfig::min_clearance_m: fallback viewpoints face shelving and clutter from close
  /// in, where thin posts (narrower than a voxel) can be missing from the map. 0.4 m rather than
  /// 0.5 m: the warehouse's shelf interiors are seen only from aisles 0.6-0.7 m wide, where no
  /// candidate keeps 0.5 m (docs/exploration.md, "Fallback viewpoints").
  double min_clearance_m = 0.4;
  /// A fallback viewpoint passes when it sees more than min_visible_samples of the cluster's
  /// samples or at least this fraction of them (a cluster of 12 samples passes with 6); (0, 1]
  double min_visible_fraction = 0.5;
  /// ... and more than this many is always enough; [0, 1e6]. FUEL's 15 (ViewpointConfig's) by
  /// default; lower lets a large cluster seen only through narrow openings (goods on shelving,
  /// each gap showing a few of its voxels) be visited a look at a time.
  int min_visible_samples = 15;
  /// A cluster of at least large_cluster_voxels frontier voxels passes with more than
  /// large_min_visible_samples instead, when that is lower: goods on shelving show a large cluster
  /// a few voxels per gap, while a low threshold for every cluster sends the vehicle on many small
  /// looks (docs/exploration.md, "Stop 83"). [1, 1e9] and [0, 1e6]; 15 (the default) leaves it off.
  int large_cluster_voxels = 100;
  int large_min_visible_samples = 15;

  /// The threshold for `cluster` (before the fraction rule): min_visible_samples, or the lower
  /// large_min_visible_samples for a cluster of at least large_cluster_voxels voxels.
  int minVisibleSamples(const FrontierCluster& cluster) const;
  void validate() const;
};

struct ViewpointConfig {
  double ring_radius_min_m = 1.5;  ///< FUEL candidate_rmin; (0, ring_radius_max_m]
  double ring_radius_max_m = 2.5;  ///< FUEL candidate_rmax; [ring_radius_min_m, 100]
  int ring_count = 4;              ///< radii evenly spaced from min to max (FUEL: rnum 3 steps = 4 rings); [1, 100]
  double angle_step_deg = 15.0;    ///< FUEL candidate_dphi; (0, 180]
  /// Heights of the rings relative to the cluster's centroid (FUEL: only 0); each in [-100, 100].
  std::vector<double> height_offsets_m = {0.0};
  /// Every voxel within this distance of a viewpoint is known-free (FUEL rejects candidates within
  /// 0.2 m of occupied and ~0.2 m of unknown space). Keep it >= the path clearance so that
  /// viewpoints are valid path goals; [0, 10]
  double min_clearance_m = 0.3;
  /// FUEL min_visib_num: a viewpoint must see more than this many cluster samples; [0, 1e6]
  int min_visible_samples = 15;
  /// What seeing a frontier sample means (observedSamples): looking into one of its unknown
  /// neighbours (true), which makes the unknown known, or, as FUEL, seeing the free voxel itself
  /// (false), which a camera can do with the unknown beside it out of sight, e.g. a shelf board's
  /// top seen from its own height: such visits fail again and again. Off by default until its
  /// runs hold up (docs/exploration.md, "Stop 51").
  bool look_into_unknown = false;
  /// With look_into_unknown: the ray toward an unknown neighbour may enter unknown space this many
  /// voxels (max norm) off it and still observe it (0: only by entering the neighbour itself,
  /// which rays that cross a frontier at a slant seldom do); [0, 100]
  int unknown_entry_reach_vox = 1;
  /// With look_into_unknown: a cluster that no candidate observes that way gets viewpoints by
  /// FUEL's rule (Viewpoint::looks_into_unknown false), e.g. the top of a board the camera will see
  /// once it flies closer; off: such a cluster has none until its viewpoints are computed again.
  bool voxel_rule_fallback = true;
  /// With FUEL's rule (look_into_unknown off): a sample whose unknown face neighbours all lie
  /// straight above or below it counts only when observed as look_into_unknown observes it; the
  /// others by FUEL's rule. A level camera at a board's height sees the free voxels on its top but
  /// not into the unknown above them, so visits there fail (docs/exploration.md, "Stop 87"). The
  /// exploration manager keeps it until no target is left, and scores by FUEL's rule from then on.
  bool vertical_into_unknown = false;
  /// Where unknown voxels make frontiers (FrontierConfig::bounds_W): one outside it is no reason
  /// to fly anywhere. Unset: no limit.
  std::optional<Eigen::AlignedBox3d> frontier_bounds_W;
  CameraFrustum camera;
  ViewpointFallback fallback;
  /// The exploration box: candidates are moved to its height range (so clusters at the floor or
  /// the ceiling get viewpoints just inside it) and rejected outside it in x-y. Unset: no limit.
  std::optional<Eigen::AlignedBox3d> bounds_W;

  void validate() const;
};
using ViewpointParams [[deprecated("renamed ViewpointConfig")]] = ViewpointConfig;

/// The name `--view-score` and summary.json give ViewpointConfig::look_into_unknown:
/// "into-unknown" (true) or "voxel" (false, FUEL's rule).
const char* viewScoreName(bool look_into_unknown);

struct Viewpoint {
  Vec3d position_W = Vec3d::Zero();
  double yaw_rad = 0.0;
  int visible_samples = 0;  ///< cluster samples seen from here (the score)
  /// The rule visible_samples counts by: ViewpointConfig::look_into_unknown, or false when the
  /// viewpoint is FUEL's rule's fallback.
  bool looks_into_unknown = false;

  FlatPose pose() const { return {position_W, yaw_rad}; }
};

/// The viewpoints of one cluster, best first (most samples seen; ties by ring order, which is
/// deterministic): the ring candidates, or when none passes (and params.fallback.enabled) the
/// fallback's. Empty when neither search finds one: the cluster cannot be observed for now.
std::vector<Viewpoint> computeViewpoints(const FrontierCluster& cluster, const MapQuery& map,
                                         const ViewpointConfig& params = {});

/// computeViewpoints for several clusters in parallel (one task per cluster); results in the
/// order of `clusters`, identical to calling computeViewpoints on each.
std::vector<std::vector<Viewpoint>> computeViewpoints(const std::vector<const FrontierCluster*>& clusters,
                                                      const MapQuery& map, const ViewpointConfig& params = {});

/// Yaw toward a set of voxels from `eye_W`: the circular mean of the horizontal directions.
double yawToward(const Vec3d& eye_W, const std::vector<openvdb::Coord>& voxels, const MapQuery& map);

/// How many of `voxels` a camera at eye_W with yaw sees (frustum, range, and no occupied or
/// unknown voxel on the ray from the voxel's centre to the eye).
int countVisible(MapProbe& probe, const Vec3d& eye_W, double yaw_rad, const std::vector<openvdb::Coord>& voxels,
                 const CameraFrustum& camera);

/// The voxels that countVisible counts, in the order of `voxels`.
std::vector<openvdb::Coord> visibleVoxels(MapProbe& probe, const Vec3d& eye_W, double yaw_rad,
                                          const std::vector<openvdb::Coord>& voxels, const CameraFrustum& camera);

/// The frontier samples a camera at eye_W with yaw observes, in the order of `samples`: with
/// params.look_into_unknown, those with an unknown face neighbour (inside frontier_bounds_W) whose
/// centre is in the frustum and whose ray from the eye leaves known-free space within
/// unknown_entry_reach_vox of it, into unknown space (MapProbe::firstNotFree); else
/// visibleVoxels. What viewpoints are scored by and what a visit is judged by.
std::vector<openvdb::Coord> observedSamples(MapProbe& probe, const Vec3d& eye_W, double yaw_rad,
                                            const std::vector<openvdb::Coord>& samples, const ViewpointConfig& params);
/// observedSamples(...).size().
int countObserved(MapProbe& probe, const Vec3d& eye_W, double yaw_rad, const std::vector<openvdb::Coord>& samples,
                  const ViewpointConfig& params);
/// !observedSamples(...).empty(), stopping at the first sample observed.
bool observesAny(MapProbe& probe, const Vec3d& eye_W, double yaw_rad, const std::vector<openvdb::Coord>& samples,
                 const ViewpointConfig& params);

}  // namespace vdbmap::planner
