#include "vdbmap/planner/viewpoint.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

namespace vdbmap::planner {

namespace {
[[noreturn]] void fail(const char* type, const std::string& field, const std::string& range) {
  throw std::invalid_argument(std::string(type) + "." + field + " must be in " + range);
}
}  // namespace

void CameraFrustum::validate() const {
  if (!(tan_half_fov_x > 0.0 && tan_half_fov_x <= 100.0)) fail("CameraFrustum", "tan_half_fov_x", "(0, 100]");
  if (!(tan_half_fov_y > 0.0 && tan_half_fov_y <= 100.0)) fail("CameraFrustum", "tan_half_fov_y", "(0, 100]");
  if (!(max_range_m > 0.0 && max_range_m <= 1e3)) fail("CameraFrustum", "max_range_m", "(0, 1000]");
  if (!(min_range_m >= 0.0 && min_range_m < max_range_m)) fail("CameraFrustum", "min_range_m", "[0, max_range_m)");
}

namespace {
/// CameraFrustum::contains with the cosine and sine of the yaw given: a view tests many points.
bool frustumContains(const CameraFrustum& camera, const Vec3d& eye_W, double cos_yaw, double sin_yaw,
                     const Vec3d& p_W) {
  const Vec3d d = p_W - eye_W;
  const double range2 = d.squaredNorm();
  if (range2 > camera.max_range_m * camera.max_range_m || range2 < camera.min_range_m * camera.min_range_m)
    return false;
  // Camera axes at zero pitch: forward along yaw, left, up.
  const double forward = cos_yaw * d.x() + sin_yaw * d.y();
  const double left = -sin_yaw * d.x() + cos_yaw * d.y();
  if (forward <= 0.0) return false;
  return std::abs(left) <= camera.tan_half_fov_x * forward && std::abs(d.z()) <= camera.tan_half_fov_y * forward;
}
}  // namespace

bool CameraFrustum::contains(const Vec3d& eye_W, double yaw_rad, const Vec3d& p_W) const {
  return frustumContains(*this, eye_W, std::cos(yaw_rad), std::sin(yaw_rad), p_W);
}

std::optional<Vec3d> CameraFrustum::nearestInViewOnVertical(const Vec3d& eye_W, const Vec3d& p_W, double min_across_m,
                                                            double yaw_tolerance_rad) const {
  if (!(yaw_tolerance_rad >= 0.0 && yaw_tolerance_rad < M_PI / 2 && std::tan(yaw_tolerance_rad) <= tan_half_fov_x))
    throw std::invalid_argument(
        "CameraFrustum::nearestInViewOnVertical: yaw_tolerance_rad must lie in [0, pi/2) "
        "and within the horizontal half field of view, got " +
        std::to_string(yaw_tolerance_rad));
  const Vec3d d = p_W - eye_W;
  const double across_m = d.head<2>().norm(), rise_m = across_m * std::cos(yaw_tolerance_rad) * tan_half_fov_y;
  if (std::abs(d.z()) <= rise_m) return p_W;
  if (across_m < min_across_m || across_m == 0.0) return std::nullopt;
  return Vec3d(p_W.x(), p_W.y(), eye_W.z() + std::copysign(rise_m, d.z()));
}

void ViewpointFallback::validate() const {
  if (!(ring_radius_min_m > 0.0)) fail("ViewpointFallback", "ring_radius_min_m", "(0, ring_radius_max_m]");
  if (!(ring_radius_max_m >= ring_radius_min_m && ring_radius_max_m <= 100.0))
    fail("ViewpointFallback", "ring_radius_max_m", "[ring_radius_min_m, 100]");
  if (ring_count < 1 || ring_count > 100) fail("ViewpointFallback", "ring_count", "[1, 100]");
  if (height_offsets_m.empty()) fail("ViewpointFallback", "height_offsets_m", "non-empty lists");
  for (const double h : height_offsets_m)
    if (!(h >= -100.0 && h <= 100.0)) fail("ViewpointFallback", "height_offsets_m[]", "[-100, 100]");
  if (!(min_clearance_m >= 0.0 && min_clearance_m <= 10.0)) fail("ViewpointFallback", "min_clearance_m", "[0, 10]");
  if (!(min_visible_fraction > 0.0 && min_visible_fraction <= 1.0))
    fail("ViewpointFallback", "min_visible_fraction", "(0, 1]");
  if (min_visible_samples < 0 || min_visible_samples > 1000000)
    fail("ViewpointFallback", "min_visible_samples", "[0, 1e6]");
  if (large_cluster_voxels < 1 || large_cluster_voxels > 1000000000)
    fail("ViewpointFallback", "large_cluster_voxels", "[1, 1e9]");
  if (large_min_visible_samples < 0 || large_min_visible_samples > 1000000)
    fail("ViewpointFallback", "large_min_visible_samples", "[0, 1e6]");
}

int ViewpointFallback::minVisibleSamples(const FrontierCluster& cluster) const {
  return cluster.voxels.size() >= std::size_t(large_cluster_voxels)
             ? std::min(min_visible_samples, large_min_visible_samples)
             : min_visible_samples;
}

const char* viewScoreName(bool look_into_unknown) { return look_into_unknown ? "into-unknown" : "voxel"; }

void ViewpointConfig::validate() const {
  camera.validate();
  fallback.validate();
  if (!(ring_radius_min_m > 0.0)) fail("ViewpointConfig", "ring_radius_min_m", "(0, ring_radius_max_m]");
  if (!(ring_radius_max_m >= ring_radius_min_m && ring_radius_max_m <= 100.0))
    fail("ViewpointConfig", "ring_radius_max_m", "[ring_radius_min_m, 100]");
  if (ring_count < 1 || ring_count > 100) fail("ViewpointConfig", "ring_count", "[1, 100]");
  if (!(angle_step_deg > 0.0 && angle_step_deg <= 180.0)) fail("ViewpointConfig", "angle_step_deg", "(0, 180]");
  if (height_offsets_m.empty()) fail("ViewpointConfig", "height_offsets_m", "non-empty lists");
  for (const double h : height_offsets_m)
    if (!(h >= -100.0 && h <= 100.0)) fail("ViewpointConfig", "height_offsets_m[]", "[-100, 100]");
  if (!(min_clearance_m >= 0.0 && min_clearance_m <= 10.0)) fail("ViewpointConfig", "min_clearance_m", "[0, 10]");
  if (min_visible_samples < 0 || min_visible_samples > 1000000)
    fail("ViewpointConfig", "min_visible_samples", "[0, 1e6]");
  if (unknown_entry_reach_vox < 0 || unknown_entry_reach_vox > 100)
    fail("ViewpointConfig", "unknown_entry_reach_vox", "[0, 100]");
  if (bounds_W && bounds_W->isEmpty()) fail("ViewpointConfig", "bounds_W", "non-empty boxes");
  if (frontier_bounds_W && frontier_bounds_W->isEmpty())
    fail("ViewpointConfig", "frontier_bounds_W", "non-empty boxes");
}

double yawToward(const Vec3d& eye_W, const std::vector<openvdb::Coord>& voxels, const MapQuery& map) {
  const double voxel_size_m = map.voxelSize();
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (const openvdb::Coord& c : voxels) {
    const Eigen::Vector2d d = (voxelCenterOf(c, voxel_size_m) - eye_W).head<2>();
    const double n = d.norm();
    if (n > 1e-9) sum += d / n;
  }
  return sum.squaredNorm() > 0.0 ? std::atan2(sum.y(), sum.x()) : 0.0;
}

namespace {
/// Whether a camera at eye_W whose yaw has cosine c and sine s sees the centre of voxel v: inside
/// the frustum and range, nothing but known-free voxels on the ray.
bool seesCentre(MapProbe& probe, const Vec3d& eye_W, double c, double s, const openvdb::Coord& v,
                const CameraFrustum& camera) {
  const Vec3d p = voxelCenterOf(v, probe.voxelSize());
  return frustumContains(camera, eye_W, c, s, p) && probe.isVisible(p, eye_W);
}

/// Calls on_seen(voxel), until it returns false, for each voxel whose centre the camera sees.
template <typename OnSeen>
void forEachSeen(MapProbe& probe, const Vec3d& eye_W, double yaw_rad, const std::vector<openvdb::Coord>& voxels,
                 const CameraFrustum& camera, OnSeen&& on_seen) {
  const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
  for (const openvdb::Coord& v : voxels)
    if (seesCentre(probe, eye_W, c, s, v, camera) && !on_seen(v)) return;
}
}  // namespace

int countVisible(MapProbe& probe, const Vec3d& eye_W, double yaw_rad, const std::vector<openvdb::Coord>& voxels,
                 const CameraFrustum& camera) {
  int seen = 0;
  forEachSeen(probe, eye_W, yaw_rad, voxels, camera, [&](const openvdb::Coord&) { return ++seen > 0; });
  return seen;
}

std::vector<openvdb::Coord> visibleVoxels(MapProbe& probe, const Vec3d& eye_W, double yaw_rad,
                                          const std::vector<openvdb::Coord>& voxels, const CameraFrustum& camera) {
  std::vector<openvdb::Coord> seen;
  forEachSeen(probe, eye_W, yaw_rad, voxels, camera, [&](const openvdb::Coord& v) {
    seen.push_back(v);
    return true;
  });
  return seen;
}

namespace {
int maxNorm(const openvdb::Coord& d) { return std::max({std::abs(d.x()), std::abs(d.y()), std::abs(d.z())}); }

/// Whether a face neighbour of `v` beside it (not above or below) is unknown.
bool unknownBeside(MapProbe& probe, const openvdb::Coord& v) {
  for (const openvdb::Coord& d : kFaceNeighbours)
    if (d.z() == 0 && probe.at(v + d) == Occupancy::Unknown) return true;
  return false;
}

/// Calls on_observed(sample) for each sample observedSamples() returns (until it returns false).
template <typename OnObserved>
void forEachObserved(MapProbe& probe, const Vec3d& eye_W, double yaw_rad, const std::vector<openvdb::Coord>& samples,
                     const ViewpointConfig& params, OnObserved&& on_observed) {
  if (!params.look_into_unknown && !params.vertical_into_unknown)
    return forEachSeen(probe, eye_W, yaw_rad, samples, params.camera, on_observed);
  const double voxel_size_m = probe.voxelSize();
  const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
  const Eigen::AlignedBox3d* bounds = params.frontier_bounds_W ? &*params.frontier_bounds_W : nullptr;
  const auto looks_into_unknown = [&](const openvdb::Coord& v) {
    for (const openvdb::Coord& d : kFaceNeighbours) {
      const openvdb::Coord n = v + d;
      if (probe.at(n) != Occupancy::Unknown) continue;
      const Vec3d p = voxelCenterOf(n, voxel_size_m);
      if ((bounds && !bounds->contains(p)) || !frustumContains(params.camera, eye_W, c, s, p)) continue;
      // The ray toward n enters unknown space at n or near it; one entering it farther off runs
      // along the unknown's edge, as toward the top of a board seen edge-on.
      const std::optional<openvdb::Coord> entry = probe.firstNotFree(eye_W, p);
      if (entry && probe.at(*entry) == Occupancy::Unknown && maxNorm(*entry - n) <= params.unknown_entry_reach_vox)
        return true;
    }
    return false;
  };
  for (const openvdb::Coord& v : samples) {
    const bool observed = !params.look_into_unknown && unknownBeside(probe, v)
                              ? seesCentre(probe, eye_W, c, s, v, params.camera)
                              : looks_into_unknown(v);
    if (observed && !on_observed(v)) return;
  }
}
}  // namespace

std::vector<openvdb::Coord> observedSamples(MapProbe& probe, const Vec3d& eye_W, double yaw_rad,
                                            const std::vector<openvdb::Coord>& samples, const ViewpointConfig& params) {
  std::vector<openvdb::Coord> seen;
  forEachObserved(probe, eye_W, yaw_rad, samples, params, [&](const openvdb::Coord& v) {
    seen.push_back(v);
    return true;
  });
  return seen;
}

int countObserved(MapProbe& probe, const Vec3d& eye_W, double yaw_rad, const std::vector<openvdb::Coord>& samples,
                  const ViewpointConfig& params) {
  int seen = 0;
  forEachObserved(probe, eye_W, yaw_rad, samples, params, [&](const openvdb::Coord&) { return ++seen > 0; });
  return seen;
}

bool observesAny(MapProbe& probe, const Vec3d& eye_W, double yaw_rad, const std::vector<openvdb::Coord>& samples,
                 const ViewpointConfig& params) {
  bool any = false;
  forEachObserved(probe, eye_W, yaw_rad, samples, params, [&](const openvdb::Coord&) { return !(any = true); });
  return any;
}

namespace {

/// One set of rings around a cluster's centroid.
struct Rings {
  double radius_min_m, radius_max_m;
  int count;
  const std::vector<double>& height_offsets_m;
  double min_clearance_m;
  int min_visible_samples;  ///< a candidate must see more than this

  double radius(int ring) const {
    return count == 1 ? radius_min_m : radius_min_m + (radius_max_m - radius_min_m) * ring / (count - 1);
  }
};

/// The candidates on `rings` that pass, in ring order.
/// `probe` checks clearance, `sight` (on the map's sightMap(); `probe` itself when that is the
/// same map) what a candidate sees.
void searchRings(const FrontierCluster& cluster, MapProbe& probe, MapProbe& sight, const ViewpointConfig& params,
                 const Rings& rings, std::vector<Viewpoint>& out) {
  const MapQuery& map = probe.map();
  // Every check below stays within the outer ring, the samples, and the clearance around them:
  // read that region once (on maps where that pays: the clearance checks read a small part of it).
  {
    const double reach = rings.radius_max_m + rings.min_clearance_m + map.voxelSize();
    double dz_lo = 0.0, dz_hi = 0.0;
    for (const double h : rings.height_offsets_m) dz_lo = std::min(dz_lo, h), dz_hi = std::max(dz_hi, h);
    const double margin_z = rings.min_clearance_m + map.voxelSize();
    Eigen::AlignedBox3d region(cluster.centroid_W - Vec3d(reach, reach, margin_z - dz_lo),
                               cluster.centroid_W + Vec3d(reach, reach, margin_z + dz_hi));
    for (const openvdb::Coord& c : cluster.samples) region.extend(map.voxelCenter(c));
    const openvdb::CoordBBox block = map.voxelsIn(region).expandBy(1);
    if (map.boxReadsPay()) probe.cacheBox(block);
    if (&sight != &probe && sight.map().boxReadsPay()) sight.cacheBox(block);
  }
  const double step = params.angle_step_deg * M_PI / 180.0;
  const int angles = std::max(1, int(std::ceil(2.0 * M_PI / step - 1e-9)));
  for (const double dz : rings.height_offsets_m) {
    for (int ring = 0; ring < rings.count; ++ring) {
      const double radius = rings.radius(ring);
      for (int k = 0; k < angles; ++k) {
        const double phi = -M_PI + k * step;
        Vec3d p = cluster.centroid_W + Vec3d(radius * std::cos(phi), radius * std::sin(phi), dz);
        // Clusters near the floor or the ceiling (a level camera sees them last) are viewed from
        // the nearest allowed height, slightly below or above: they stay in the vertical field of view.
        if (params.bounds_W) p.z() = std::clamp(p.z(), params.bounds_W->min().z(), params.bounds_W->max().z());
        if (params.bounds_W && !params.bounds_W->contains(p)) continue;
        if (!probe.isClear(p, rings.min_clearance_m)) continue;
        const double yaw = yawToward(p, cluster.samples, map);
        const int seen = countObserved(sight, p, yaw, cluster.samples, params);
        if (seen > rings.min_visible_samples) out.push_back({p, yaw, seen, params.look_into_unknown});
      }
    }
  }
}

}  // namespace

std::vector<Viewpoint> computeViewpoints(const FrontierCluster& cluster, const MapQuery& map,
                                         const ViewpointConfig& params) {
  params.validate();
  std::vector<Viewpoint> viewpoints;
  if (cluster.samples.empty()) return viewpoints;
  MapProbe probe(map);
  std::optional<MapProbe> own_sight;
  MapProbe& sight = &map.sightMap() == &map ? probe : own_sight.emplace(map.sightMap());
  const auto search = [&](const ViewpointConfig& p) {
    searchRings(cluster, probe, sight, p,
                {p.ring_radius_min_m, p.ring_radius_max_m, p.ring_count, p.height_offsets_m, p.min_clearance_m,
                 p.min_visible_samples},
                viewpoints);
    const ViewpointFallback& fb = p.fallback;
    if (viewpoints.empty() && fb.enabled) {
      // A candidate passes (seen > threshold) with ceil(fraction x samples) samples, or with more
      // than the cluster's minVisibleSamples, and never with none.
      const int fraction_of_samples = int(std::ceil(fb.min_visible_fraction * double(cluster.samples.size()))) - 1;
      const int threshold = std::max(0, std::min(fb.minVisibleSamples(cluster), fraction_of_samples));
      searchRings(cluster, probe, sight, p,
                  {fb.ring_radius_min_m, fb.ring_radius_max_m, fb.ring_count, fb.height_offsets_m, fb.min_clearance_m,
                   threshold},
                  viewpoints);
    }
  };
  search(params);
  if (viewpoints.empty() && params.look_into_unknown && params.voxel_rule_fallback) {
    ViewpointConfig fuel = params;
    fuel.look_into_unknown = false;
    fuel.vertical_into_unknown = false;
    search(fuel);
  }
  std::stable_sort(viewpoints.begin(), viewpoints.end(),
                   [](const Viewpoint& a, const Viewpoint& b) { return a.visible_samples > b.visible_samples; });
  return viewpoints;
}

std::vector<std::vector<Viewpoint>> computeViewpoints(const std::vector<const FrontierCluster*>& clusters,
                                                      const MapQuery& map, const ViewpointConfig& params) {
  params.validate();
  std::vector<std::vector<Viewpoint>> views(clusters.size());
  tbb::parallel_for(std::size_t(0), clusters.size(), [&](std::size_t i) { views[i] = computeViewpoints(*clusters[i], map, params); });
  return views;
}

}  // namespace vdbmap::planner
