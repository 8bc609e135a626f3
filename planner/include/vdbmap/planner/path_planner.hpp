// Collision-free paths through known-free space.
//
// First the straight segment, when it is clear; otherwise a search (PathConfig::search): OMPL's
// RRTConnect, then OMPL's PathSimplifier (vertex reduction and shortcutting, no B-spline
// smoothing: the trajectory module rounds corners itself), or A* on a lattice of voxel centres
// (grid_search.hpp: complete at its resolution, as FUEL prices its legs), or the lattice where
// RRTConnect finds nothing. The search space is the map's known bounds (a path can only run
// through known-free voxels) intersected with an optional box. Collision checks are MapProbe's
// exact capsule test: every voxel whose centre lies within clearance_m of any point of the path
// is known-free. OMPL's own validity-check resolution (used where OMPL interpolates by itself) is
// set from metres, not from its default fraction of the space's extent. Every returned path is
// re-checked with the capsule test before it is returned.
//
// Determinism: each query seeds the sampler and the simplifier from (seed, query_seed), so the
// same map, query and seed give the same path whatever ran before, as long as the planner does
// not hit its time limit (a timeout is a status, never an exception). The lattice search samples
// nothing; its budget is counted in expansions.
//
// Threads: a PathPlanner holds a map reader; use one planner per thread. With the lattice search
// the map must not change while the planner lives (it keeps clearance answers from query to query).
#pragma once

#include "vdbmap/planner/grid_search.hpp"
#include "vdbmap/planner/map_query.hpp"

#include <Eigen/Geometry>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace vdbmap::planner {

/// How a path is searched when the straight segment is blocked.
enum class PathSearch {
  Sampling,          ///< OMPL's RRTConnect and simplifier
  Grid,              ///< A* on a lattice (GridSearch)
  SamplingThenGrid,  ///< RRTConnect; the lattice where it finds nothing
};
const char* toString(PathSearch s);

struct PathConfig {
  /// Every voxel within this distance of the path is known-free: the vehicle's radius plus a
  /// margin (FUEL inflates obstacles by 0.2 m). 0.3 = the simulator's 0.2 m vehicle radius plus
  /// one 0.1 m voxel, since a free voxel's centre can lie up to a voxel from the surface it
  /// borders (with 0.25 m the house and warehouse flights grazed surfaces at 0.19 m); [0, 5]
  double clearance_m = 0.3;
  /// OMPL's validity-check resolution in metres (segments themselves are checked exactly);
  /// 0 = half a voxel; [0, 1]
  double check_step_m = 0.0;
  /// Wall-clock budget of one RRTConnect search; (0, 60]
  double time_limit_s = 0.05;
  /// Iteration budget of one RRTConnect search (its termination checks, one per tree extension);
  /// 0 = only the time limit; [0, 1e9]. With a cap that binds before the time limit, a search's
  /// outcome no longer depends on the machine's speed or load.
  std::uint64_t max_iterations = 0;
  /// RRTConnect's maximum extension length in metres; 0 = OMPL's default (a fifth of the space's
  /// extent); [0, 1e3]
  double rrt_range_m = 0.0;
  PathSearch search = PathSearch::Sampling;
  /// The lattice search's settings (search Grid or SamplingThenGrid); its clearance is clearance_m.
  GridSearchConfig grid;
  /// Shortcutting rounds of the simplifier (each: vertex reduction, then shortcuts); [0, 100]
  int simplify_rounds = 3;
  std::uint64_t seed = 1;
  /// Limits the search space (intersected with the map's known bounds). Unset: known bounds only.
  std::optional<Eigen::AlignedBox3d> bounds_W;

  void validate() const;
};
using PathParams [[deprecated("renamed PathConfig")]] = PathConfig;

enum class PathStatus {
  Straight,      ///< the straight segment is clear
  Planned,       ///< found by a search (RRTConnect and simplified, or the lattice and shortened)
  StartInvalid,  ///< the start is not clear (too near occupied or unknown space) or out of bounds
  GoalInvalid,   ///< the goal is not clear or out of bounds
  NoPath,        ///< no path found within the time limit (or the iteration / expansion budget)
};
const char* toString(PathStatus s);

struct PathResult {
  PathStatus status = PathStatus::NoPath;
  std::vector<Vec3d> waypoints;  ///< start ... goal (empty unless ok())
  double length_m = 0.0;         ///< polyline length (0 unless ok())
  double time_s = 0.0;           ///< time spent
  std::uint64_t iterations = 0;  ///< RRTConnect iterations or lattice expansions (0 when no search was needed)

  bool ok() const { return status == PathStatus::Straight || status == PathStatus::Planned; }
};

/// Length of a polyline.
double polylineLength(const std::vector<Vec3d>& points);

class PathPlanner {
 public:
  /// The map must outlive the planner and not change while the planner is used (it keeps the
  /// clearance answers it found, as the lattice search does). Throws
  /// std::invalid_argument for bad parameters.
  PathPlanner(const MapQuery& map, const PathConfig& params = {});
  ~PathPlanner();
  PathPlanner(PathPlanner&&) noexcept;
  PathPlanner& operator=(PathPlanner&&) noexcept;

  const PathConfig& params() const { return params_; }

  /// A path from start to goal. `query_seed` is mixed into the seed (e.g. a pair index, so that
  /// parallel queries do not depend on which thread runs them).
  PathResult plan(const Vec3d& start_W, const Vec3d& goal_W, std::uint64_t query_seed = 0);

  /// The collision test paths are held to: the point is in the search space and every voxel
  /// within clearance_m of it is known-free.
  bool isClear(const Vec3d& p_W);
  /// MapProbe::isSegmentClear with clearance_m, inside the search space.
  bool isSegmentClear(const Vec3d& a_W, const Vec3d& b_W);
  /// The search space: the map's known bounds (at construction) intersected with bounds_W.
  const Eigen::AlignedBox3d& searchBounds() const;

 private:
  struct Checker;
  struct Ompl;
  PathResult searchOmpl(const Vec3d& start_W, const Vec3d& goal_W, std::uint64_t seed);
  PathResult searchGrid(const Vec3d& start_W, const Vec3d& goal_W);

  PathConfig params_;
  std::unique_ptr<Checker> checker_;
  std::unique_ptr<Ompl> ompl_;  ///< created on the first search that needs it
  std::unique_ptr<GridSearch> grid_;  ///< likewise; keeps its clearance answers for the planner's life
};

}  // namespace vdbmap::planner
