#include "vdbmap/planner/tour.hpp"

#include <stdexcept>
#include <string>

namespace vdbmap::planner {

void TourConfig::validate() const {
  if (!(time_limit_s > 0.0 && time_limit_s <= 60.0))
    throw std::invalid_argument("TourConfig.time_limit_s must be in (0, 60]");
}

double openTourCost(const RealCostMatrix& costs, const std::vector<std::size_t>& order) {
  const std::size_t n = costs.size();
  if (n == 0 || order.size() + 1 != n)
    throw std::invalid_argument("openTourCost: " + std::to_string(order.size()) + " stops for a matrix of " +
                                std::to_string(n) + " nodes (the vehicle and n - 1 targets)");
  std::vector<bool> seen(n, false);
  double cost = 0.0;
  std::size_t at = 0;
  for (const std::size_t target : order) {
    if (target + 1 >= n || seen[target + 1])
      throw std::invalid_argument("openTourCost: the order is not a permutation of the targets");
    seen[target + 1] = true;
    cost += costs(at, target + 1);
    at = target + 1;
  }
  return cost;
}

TourResult solveOpenTour(const RealCostMatrix& costs, const TourConfig& params) {
  params.validate();
  TourResult result;
  const std::size_t n = costs.size();
  if (n <= 2) {  // no target, or one: nothing to order
    if (n == 2) result.order = {0};
    result.cost_s = n == 2 ? costs(0, 1) : 0.0;
    result.optimal_proven = true;
    return result;
  }
  AtspConfig options;
  options.time_limit_s = params.time_limit_s;
  options.seed = params.seed;
  options.max_iterations = params.max_iterations;
  options.max_stale_iterations = params.max_stale_iterations;
  options.open_from = 0;
  const AtspResult solved = solveAtsp(costs, options);
  // The solver's order starts at node 0 (the vehicle); targets are nodes 1..n-1.
  for (std::size_t i = 1; i < solved.order.size(); ++i) result.order.push_back(solved.order[i] - 1);
  result.cost_s = openTourCost(costs, result.order);
  result.optimal_proven = solved.optimal_proven;
  result.status = solved.status;
  result.time_s = solved.time_s;
  return result;
}

GlobalTour planGlobalTour(const MapQuery& map, const VehicleState& vehicle, const std::vector<TourTarget>& targets,
                          PairCostTable& table, const TourConfig& tour) {
  GlobalTour g;
  table.update(map, targets, tour.max_planned_pairs);
  g.from_vehicle = costsFromVehicle(map, vehicle, targets, table.costParams(), table.pathParams());
  std::vector<double> row;
  for (const LegCost& leg : g.from_vehicle) row.push_back(leg.cost_s);
  g.costs = buildTourCostMatrix(row, targets, table);
  g.tour = solveOpenTour(g.costs, tour);
  return g;
}

}  // namespace vdbmap::planner
