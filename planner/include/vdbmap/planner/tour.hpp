// The global exploration tour (FUEL, Zhou et al. 2021, Sect. V-B): from the vehicle, visit every
// cluster's best viewpoint once, in the cheapest order, without returning: an open asymmetric TSP
// (costs from the vehicle include its velocity; the return column is zero), solved by the
// project's own solver (atsp.hpp) under a time limit.
#pragma once

#include "vdbmap/planner/atsp.hpp"
#include "vdbmap/planner/cost.hpp"

#include <cstdint>
#include <vector>

namespace vdbmap::planner {

struct TourConfig {
  double time_limit_s = 0.05;  ///< solver budget; (0, 60]
  std::uint64_t seed = 1;      ///< solver seed
  /// Solver rounds (0 = only the time limit). With a cap the tour no longer depends on machine
  /// speed, unless the time limit is reached first.
  std::uint64_t max_iterations = 0;
  /// Solver rounds in a row without a shorter tour after which it stops (0 = never). Tours of
  /// tens of clusters settle within a few hundred rounds (docs/atsp.md): in the runs logged there
  /// 500 kept every tour that 1500 found, at a third of the solve time.
  std::uint64_t max_stale_iterations = 500;
  /// Pairs of targets planned per planGlobalTour at most (0 = all); the others hold the straight
  /// leg's cost until a later call plans them (PairCostTable::update). A burst of new clusters
  /// then spreads over several replans instead of stalling one.
  std::size_t max_planned_pairs = 0;
  void validate() const;
};
using TourParams [[deprecated("renamed TourConfig")]] = TourConfig;

struct TourResult {
  std::vector<std::size_t> order;  ///< target indices in visiting order (node 0, the vehicle, left out)
  double cost_s = 0.0;             ///< the open tour's cost, recomputed from the matrix
  bool optimal_proven = false;
  AtspStatus status = AtspStatus::kOptimal;
  double time_s = 0.0;
};

/// Cost of an open tour over a matrix from buildTourCostMatrix: vehicle -> order[0] -> order[1] ...
/// Throws std::invalid_argument if `order` is not a permutation of the targets.
double openTourCost(const RealCostMatrix& costs, const std::vector<std::size_t>& order);

/// Solves the open tour from node 0 (the vehicle) over a buildTourCostMatrix matrix. With one or
/// no target the answer is immediate.
TourResult solveOpenTour(const RealCostMatrix& costs, const TourConfig& params = {});

/// Everything a replanning step needs for the tour: refreshes the pair table (only new clusters'
/// pairs are planned), plans the legs from the vehicle (with the table's cost and path
/// parameters), builds the matrix and solves it.
struct GlobalTour {
  TourResult tour;
  std::vector<LegCost> from_vehicle;  ///< per target
  RealCostMatrix costs;               ///< node 0 = vehicle, node i + 1 = targets[i]
};
GlobalTour planGlobalTour(const MapQuery& map, const VehicleState& vehicle, const std::vector<TourTarget>& targets,
                          PairCostTable& table, const TourConfig& tour = {});

}  // namespace vdbmap::planner
