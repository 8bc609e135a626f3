// A simulated world: a ground-truth triangle mesh with exact ray casting and nearest-surface
// distances, for rendering depth, checking clearance and evaluating maps.
//
// Any mesh works: non-watertight, with holes, inconsistent winding or degenerate faces, because
// nothing here needs an inside or an outside. Rays and distances are answered exactly on the
// triangles themselves (Moller-Trumbore and closest-point tests in double precision) through a
// bounding volume hierarchy (surface area heuristic), so depth is exact to rounding.
//
// Why not an OpenVDB level set: meshToLevelSet gets the sign wrong on open meshes, and sphere
// tracing an unsigned distance field cannot place the surface better than a fraction of a voxel.
// A sparse OpenVDB grid listing the triangles per cell (the narrow band around them) was the first
// implementation: exact, but the house's visual mesh packs up to 12,521 triangles into one
// 0.2 m cell (detailed furniture), and a 640x480 frame took 320 ms at the best cell size against
// 160 ms for this hierarchy, on the same loaded machine. Whole depth images are rasterized
// (depth_camera.hpp), faster still (10 ms against 49 ms for one ray per pixel on 2 idle cores,
// bench/bench_render.cpp); rays serve single queries (visibility checks).
//
// Degenerate faces (zero area, non-finite coordinates, bad vertex indices) are dropped on
// construction; `ceiling_clip_z_m` cuts every triangle at a height, so worlds built with tall
// walls and no roof (the warehouse) can be flown with a bounded altitude, and `cap_ceiling` closes
// them with a flat ceiling there.
#pragma once

#include "vdbmap/triangle_mesh.hpp"
#include "vdbmap/types.hpp"

#include <Eigen/Geometry>

#include <filesystem>
#include <limits>
#include <memory>
#include <vector>

namespace vdbmap::sim {
namespace internal {
class TriangleBvh;
}

struct WorldConfig {
  /// Cut the mesh at this height (metres, world z): parts above are removed. +inf keeps it all.
  double ceiling_clip_z_m = std::numeric_limits<double>::infinity();
  /// Close the world with a flat ceiling at ceiling_clip_z_m over the mesh's bounding box (two
  /// triangles). The shared house and warehouse meshes have no roof (measured: the house has 23 m^2
  /// of horizontal faces above 2.5 m against 247 m^2 of floor); a cap bounds what a camera sees
  /// and what a planner must explore. Needs a finite ceiling_clip_z_m.
  bool cap_ceiling = false;
  /// Faces with an area below this are degenerate and dropped. [0, 1)
  double min_triangle_area_m2 = 1e-12;

  void validate() const;
};

/// What construction kept and dropped.
struct WorldStats {
  std::size_t triangles_in = 0;
  std::size_t triangles = 0;           ///< kept (after clipping, which may split one in two)
  std::size_t degenerate_dropped = 0;  ///< zero area, non-finite, or bad vertex indices
  std::size_t clipped_away = 0;        ///< entirely above the ceiling clip
  bool capped = false;                 ///< a ceiling cap was added (2 of the triangles)
  std::size_t bvh_nodes = 0;
  int bvh_depth = 0;
};

/// The first surface a ray meets.
struct RayHit {
  double t = std::numeric_limits<double>::infinity();  ///< distance along the unit direction
  int triangle = -1;                                   ///< index into mesh().triangles, -1 = none
  bool hit() const { return triangle >= 0; }
};

class World {
 public:
  /// Builds a world from a mesh in metres (world frame, z up). Throws std::invalid_argument when
  /// the config is invalid or no usable triangle is left.
  World(const TriangleMesh& mesh, const WorldConfig& config = {});
  /// Reads a PLY, OBJ or OFF mesh (io::readTriangleMesh) and builds the world from it.
  static World load(const std::filesystem::path& mesh_file, const WorldConfig& config = {});

  World(World&&) noexcept;
  World& operator=(World&&) noexcept;
  ~World();

  /// The first hit along the unit direction `dir_W` from `origin_W` with 0 < t <= max_t.
  RayHit raycast(const Vec3d& origin_W, const Vec3d& dir_W, double max_t) const;

  /// Exact distance from p_W to the nearest triangle when it is below `max_distance_m`, else
  /// `max_distance_m` (a small bound prunes the search early).
  double distance(const Vec3d& p_W, double max_distance_m) const;
  /// True when no surface is within `clearance_m` of p_W.
  bool isClear(const Vec3d& p_W, double clearance_m) const { return distance(p_W, clearance_m) >= clearance_m; }
  /// True when the segment a-b keeps `clearance_m` from every surface, by conservative
  /// advancement: a sample at distance d certifies the next d - clearance metres, with a minimum
  /// step of clearance / 20; so samples keep the full clearance and the points between them at
  /// least 95 % of it, and no wall, however thin, slips between samples.
  bool isSegmentClear(const Vec3d& a_W, const Vec3d& b_W, double clearance_m) const;

  /// Axis-aligned box around the (clipped) mesh.
  const Eigen::AlignedBox3d& bounds() const { return bounds_; }
  /// The cleaned, clipped mesh the world is made of (for rendering and for evaluation against
  /// ground truth): the input's vertices (plus those clipping created) and the kept triangles.
  const TriangleMesh& mesh() const { return mesh_; }
  const WorldStats& stats() const { return stats_; }
  const WorldConfig& config() const { return config_; }

 private:
  WorldConfig config_;
  TriangleMesh mesh_;
  std::unique_ptr<internal::TriangleBvh> bvh_;
  Eigen::AlignedBox3d bounds_;
  WorldStats stats_;
};

}  // namespace vdbmap::sim
