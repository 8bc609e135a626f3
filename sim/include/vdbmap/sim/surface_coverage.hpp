// Exploration coverage: the fraction of a world's *observable* surface that a map knows.
//
// Definition (all in the world frame, fixed once per world, exploration box and start):
//  1. Surface samples: area-weighted random points on the world's triangles (sample_spacing_m
//     apart on average, seeded), kept when they lie inside the exploration box.
//  2. Reachable positions: the cells of a grid (grid_m) over the box whose centres keep
//     vehicle_clearance_m from every surface, 6-connected to the start's cell: where the vehicle's
//     centre can go without leaving the box or passing closer to a surface.
//  3. A sample is observable when some reachable position sees it as the vehicle's camera could:
//     at a distance in [min_view_distance_m, max_view_distance_m], with the line of sight within
//     half_fov_vertical_rad of horizontal (a zero-pitch camera: any yaw, limited elevation), and
//     the segment between them meeting no surface. Candidates are tested along a fan of directions
//     (azimuth_steps x elevation_steps within the band) at distances every grid_m.
//  4. A sample is known when the map has a known voxel (weight above tau_w: free or occupied)
//     whose centre lies within known_radius_vox voxels of it.
//  coverage = known observable samples / observable samples.
// Excluded as unobservable: surfaces outside the box (e.g. above the ceiling cap, below the
// floor), the outer faces of outer walls and the insides of walls (no reachable position in front
// of them), surfaces under furniture or in gaps narrower than the vehicle can enter and not in
// line of sight of one, and surfaces that a level camera can only see steeply from above or below
// (e.g. the top of a wardrobe close to the ceiling). Samples seen only through openings narrower
// than the directions' spacing may be missed (counted unobservable): the fan is a sampling.
#pragma once

#include "vdbmap/planner/map_query.hpp"
#include "vdbmap/sim/world.hpp"
#include "vdbmap/types.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <cstdint>
#include <vector>

namespace vdbmap::sim {

struct SurfaceCoverageConfig {
  double sample_spacing_m = 0.1;        ///< mean spacing of the surface samples; [0.005, 1]
  double grid_m = 0.1;                  ///< reachability grid and distance step; [0.02, 1]
  double vehicle_clearance_m = 0.3;     ///< as the planner's viewpoint clearance; [0, 10]
  double min_view_distance_m = 0.3;     ///< [0, max_view_distance_m)
  double max_view_distance_m = 4.5;     ///< the planner's camera range; (min_view_distance_m, 100]
  double half_fov_vertical_rad = std::atan(240.0 / 387.229);  ///< the camera's; (0, pi/2]
  int azimuth_steps = 24;               ///< [1, 360]
  int elevation_steps = 7;              ///< spread evenly over [-half_fov, +half_fov]; [1, 90]
  double known_radius_vox = 1.0;        ///< [0, 10]
  std::uint64_t seed = 1;

  void validate() const;
};

/// What the observable surface is made of.
struct ObservableSurfaceStats {
  std::size_t samples_total = 0;    ///< on the whole mesh
  std::size_t samples_in_box = 0;
  std::size_t observable = 0;
  double observable_area_m2 = 0.0;  ///< observable samples x area per sample
  std::size_t grid_cells = 0;
  std::size_t reachable_cells = 0;
  double build_s = 0.0;
};

class ObservableSurface {
 public:
  /// Computes the observable samples (parallel; a few seconds for the house). Throws
  /// std::invalid_argument for an invalid config, an empty box, or a start that is not a
  /// reachable position (inside the box and clear).
  ObservableSurface(const World& world, const Eigen::AlignedBox3d& box_W, const Vec3d& start_W,
                    const SurfaceCoverageConfig& config = {});

  const std::vector<Vec3d>& samples() const { return observable_; }
  const ObservableSurfaceStats& stats() const { return stats_; }
  const SurfaceCoverageConfig& config() const { return config_; }

  /// Fraction of the observable samples the map knows (0 when there are none).
  double coverage(const planner::MapQuery& map) const;
  /// Per observable sample: does the map know it.
  std::vector<bool> known(const planner::MapQuery& map) const;

 private:
  SurfaceCoverageConfig config_;
  std::vector<Vec3d> observable_;
  ObservableSurfaceStats stats_;
};

/// Area-weighted samples of a mesh, `spacing_m` apart on average (each triangle gets
/// area / spacing^2 samples, the fraction rounded at random), seeded.
std::vector<Vec3d> sampleSurface(const TriangleMesh& mesh, double spacing_m, std::uint64_t seed);

}  // namespace vdbmap::sim
