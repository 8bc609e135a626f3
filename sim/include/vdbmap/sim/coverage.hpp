// A built-in coverage flight for a known world: boustrophedon lanes at a fixed altitude with yaw
// sweeps, planned on the ground-truth world (not on a map) so that worlds with interior walls and
// ceilings (the house) are covered without a planner.
//
//  1. A 2D grid at `altitude_m`: a cell is free when its centre keeps clearance_m plus half the
//     cell diagonal from every surface, so every point of a straight move between neighbouring
//     free cells keeps clearance_m. The flight stays in the cells reachable from the start.
//  2. Targets: on lanes (grid rows `lane_spacing_m` apart, along the world's longer horizontal
//     axis), every `target_spacing_m` along each run of reachable cells.
//  3. Order: from the start, repeatedly the unvisited target with the least path length (grid
//     Dijkstra through doorways) plus a penalty per lane changed, which sweeps lane by lane, room
//     by room; back through the start every `return_every_m` of path and at the end. The start is
//     seen all round (a full turn there first), so each pass through it closes a loop.
//  4. Path: each leg's grid path shortened by line of sight (World::isSegmentClear).
//  5. Yaw: along every straight move the camera swings from one side of the direction of travel
//     to the other (+-sweep_amplitude_rad, one swing per `sweep_leg_m` at most), after a full
//     turn at the start.
//  6. Time: stop-and-go parametrisation within the motion limits (trajectory.hpp).
#pragma once

#include "vdbmap/sim/trajectory.hpp"
#include "vdbmap/sim/world.hpp"

#include <Eigen/Core>

#include <limits>
#include <vector>

namespace vdbmap::sim {

/// Defaults: the vehicle keeps 0.4 m from every surface; lanes, targets and sweeps are set so the
/// house world's flight lasts about 100 s (1506 frames at 15 Hz; the paper's house run has 1468),
/// with the camera's +-40 deg field of view swinging +-46 deg around the direction of travel.
struct CoverageConfig {
  double altitude_m = 1.0;             ///< flight height (world z); finite
  double clearance_m = 0.4;            ///< distance kept from every surface; (0, 10]
  double grid_cell_m = 0.05;           ///< planning grid; (0, clearance_m]
  double lane_spacing_m = 2.8;         ///< between lanes; [grid_cell_m, 1000]
  double target_spacing_m = 3.0;       ///< between targets along a lane; [grid_cell_m, 1000]
  double lane_change_penalty_m = 1.5;  ///< added per lane changed when choosing the next target; [0, 1000]
  double sweep_amplitude_rad = 0.8;    ///< yaw swing either side of the direction of travel; [0, pi]
  double sweep_leg_m = 6.0;            ///< path length of one swing at most; (0, 1000]
  bool spin_at_start = true;           ///< a full turn at the start, so later passes there close loops
  /// Go back through the start after this much path since the last pass (0 = only at the end),
  /// so loops close during the flight and not only at its end; [0, 1e6]
  double return_every_m = 25.0;
  /// Start position (x, y); NaN = the reachable free cell nearest the centre of the world's box.
  Eigen::Vector2d start_xy = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  double start_yaw = 0.0;
  MotionLimits limits;
  double dt_s = 0.005;  ///< trajectory sampling; (0, 1]

  void validate() const;
};

struct CoveragePlan {
  std::vector<FlatPose> waypoints;  ///< the stop-and-go path with yaws (unwrapped)
  SampledTrajectory trajectory;
  std::vector<Vec3d> targets;       ///< lane targets in visiting order
  std::size_t free_cells = 0;       ///< grid cells free of the world
  std::size_t reachable_cells = 0;  ///< of them, reachable from the start
  std::size_t returns = 0;          ///< passes back through the start before the end
  Vec3d start_W = Vec3d::Zero();
};

/// Plans the coverage flight. Throws std::invalid_argument for an invalid config, when the start
/// is not free, or when no free cell exists at the altitude.
CoveragePlan planCoverage(const World& world, const CoverageConfig& config = {});

}  // namespace vdbmap::sim
