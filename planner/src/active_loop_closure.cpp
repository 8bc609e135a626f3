#include "vdbmap/planner/active_loop_closure.hpp"
#include "vdbmap/field_check.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace vdbmap::planner {

void AlcConfig::validate() const {
  history.validate();
  clusters.validate();
  tour.validate();
  const FieldCheck check("AlcConfig");
  auto in = [](double v, double lo, double hi) { return v >= lo && v <= hi; };
  if (!in(epsilon, 0.0, 100.0)) check.fail("epsilon", "[0, 100]");
  if (!(search_radius_m > 0.0 && search_radius_m <= 1e3)) check.fail("search_radius_m", "(0, 1000]");
  if (!in(initial_period_s, 0.0, 1e6)) check.fail("initial_period_s", "[0, 1e6]");
  if (!(give_up_timeout_s > 0.0 && give_up_timeout_s <= 1e6)) check.fail("give_up_timeout_s", "(0, 1e6]");
  if (!in(suspension_s, 0.0, 1e6)) check.fail("suspension_s", "[0, 1e6]");
  if (!in(loop_quiet_s, 0.0, 1e6)) check.fail("loop_quiet_s", "[0, 1e6]");
  if (max_failures_per_cluster < 1 || max_failures_per_cluster > 1000) check.fail("max_failures_per_cluster", "[1, 1000]");
  if (!in(finish_loop_age_s, 0.0, 1e6)) check.fail("finish_loop_age_s", "[0, 1e6]");
  if (!(finish_search_radius_m > 0.0 && finish_search_radius_m <= 1e3))
    check.fail("finish_search_radius_m", "(0, 1000]");
  if (max_finish_detours < 1 || max_finish_detours > 100) check.fail("max_finish_detours", "[1, 100]");
  if (!(unreachable_cost_s > 0.0 && unreachable_cost_s <= 1e9)) check.fail("unreachable_cost_s", "(0, 1e9]");
}

std::string toString(AlcStatus status) {
  switch (status) {
    case AlcStatus::kDetour:
      return "detour";
    case AlcStatus::kFrontierCheaper:
      return "frontier_cheaper";
    case AlcStatus::kNoFrontier:
      return "no_frontier";
    case AlcStatus::kInitialPeriod:
      return "initial_period";
    case AlcStatus::kQuietAfterLoop:
      return "quiet_after_loop";
    case AlcStatus::kGaveUp:
      return "gave_up";
    case AlcStatus::kSuspended:
      return "suspended";
    case AlcStatus::kNoCluster:
      return "no_cluster";
    case AlcStatus::kNoReachableCluster:
      return "no_reachable_cluster";
  }
  return "unknown";
}

LegCostFunction mapLegCosts(const MapQuery& map, const CostConfig& cost, const PathConfig& path) {
  cost.validate();
  path.validate();
  return [&map, cost, path](const VehicleState& from, const std::vector<TourTarget>& to) {
    return costsFromVehicle(map, from, to, cost, path);
  };
}

LegCostFunction mapLegCosts(const MapQuery& map, const PairCostTable& table) {
  return mapLegCosts(map, table.costParams(), table.pathParams());
}

RealCostMatrix loopTourMatrix(const RealCostMatrix& frontier_costs, const std::vector<double>& from_cluster) {
  if (frontier_costs.size() != from_cluster.size() + 1)
    throw std::invalid_argument("loopTourMatrix: " + std::to_string(from_cluster.size()) +
                                " costs from the cluster for " + std::to_string(frontier_costs.size()) +
                                " tour nodes (the vehicle and the targets)");
  RealCostMatrix loop = frontier_costs;
  loop(0, 0) = 0.0;
  for (std::size_t j = 0; j < from_cluster.size(); ++j) loop(0, j + 1) = from_cluster[j];
  return loop;
}

double reachableTourCost(const RealCostMatrix& costs, const std::vector<std::size_t>& order,
                         double unreachable_cost_s) {
  openTourCost(costs, order);  // checks that `order` is a permutation of the targets
  double cost = 0.0;
  std::size_t at = 0;
  for (const std::size_t target : order) {
    const double leg = costs(at, target + 1);
    if (leg < unreachable_cost_s) cost += leg;
    at = target + 1;
  }
  return cost;
}

ActiveLoopClosure::ActiveLoopClosure(const AlcConfig& params, double flight_start_s)
    : params_(params), flight_start_s_(flight_start_s), history_(params.history), clusters_(params.clusters) {
  params_.validate();
  if (!std::isfinite(flight_start_s)) throw std::invalid_argument("ActiveLoopClosure: flight_start_s must be finite");
}

bool ActiveLoopClosure::addFlownPose(const Vec3d& position_W, double yaw_rad, double stamp_s) {
  return history_.offer(position_W, yaw_rad, stamp_s);
}

void ActiveLoopClosure::correctHistory(const std::function<FlatPose(const FlownViewpoint&)>& corrected) {
  history_.correct(corrected);
  clusters_.refresh(history_);
}

std::size_t ActiveLoopClosure::failures(LoopClusterId id) const {
  const auto it = failures_.find(id);
  return it == failures_.end() ? 0 : it->second;
}

AlcStats ActiveLoopClosure::stats(double now_s) const {
  AlcStats s = stats_;
  if (detour_) s.detour_time_s += std::max(0.0, now_s - detour_->since_s);
  return s;
}

bool ActiveLoopClosure::detourTimedOut(double now_s) const {
  return detour_ && now_s - detour_->since_s >= params_.give_up_timeout_s;
}

void ActiveLoopClosure::endDetour(double now_s) {
  stats_.detour_time_s += now_s - detour_->since_s;
  detour_.reset();
}

void ActiveLoopClosure::giveUp(double now_s) {
  ++failures_[detour_->cluster];
  ++stats_.give_ups;
  suspended_until_s_ = now_s + params_.suspension_s;
  endDetour(now_s);
}

std::optional<AlcStatus> ActiveLoopClosure::gate(double now_s, bool loop_closed) {
  if (loop_closed) {
    last_loop_s_ = now_s;
    if (detour_) {
      ++stats_.loops_on_detour;
      endDetour(now_s);
    }
  }
  if (detourTimedOut(now_s)) {
    giveUp(now_s);
    return AlcStatus::kGaveUp;
  }
  if (detour_) return std::nullopt;  // a detour in progress passed the gates when it started
  if (now_s < flight_start_s_ + params_.initial_period_s) return AlcStatus::kInitialPeriod;
  if (last_loop_s_ && now_s < *last_loop_s_ + params_.loop_quiet_s) return AlcStatus::kQuietAfterLoop;
  if (suspended_until_s_ && now_s < *suspended_until_s_) return AlcStatus::kSuspended;
  return std::nullopt;
}

std::vector<LoopClusterId> ActiveLoopClosure::candidates(const Vec3d& position_W, double radius_m) const {
  if (detour_) return {detour_->cluster};
  std::vector<LoopClusterId> usable;
  for (const LoopClusterId id : clusters_.near(history_, position_W, radius_m))
    if (failures(id) < std::size_t(params_.max_failures_per_cluster)) usable.push_back(id);
  return usable;
}

void ActiveLoopClosure::checkTime(double now_s, const char* who) {
  if (!std::isfinite(now_s) || (last_decision_s_ && now_s < *last_decision_s_))
    throw std::invalid_argument(std::string("ActiveLoopClosure::") + who + ": now_s = " + std::to_string(now_s) +
                                " s is not finite or earlier than the previous call's");
  last_decision_s_ = now_s;
}

namespace {
std::vector<LegCost> priced(const LegCostFunction& leg_costs, const VehicleState& from,
                            const std::vector<TourTarget>& to) {
  std::vector<LegCost> legs = leg_costs(from, to);
  if (legs.size() != to.size())
    throw std::invalid_argument("ActiveLoopClosure: the leg cost function returned " + std::to_string(legs.size()) +
                                " legs for " + std::to_string(to.size()) + " poses");
  return legs;
}
}  // namespace

bool ActiveLoopClosure::chooseCluster(const VehicleState& vehicle, double now_s, double radius_m,
                                      const LegCostFunction& leg_costs, AlcDecision& d) {
  const std::vector<LoopClusterId> ids = candidates(vehicle.position_W, radius_m);
  if (ids.empty()) {
    d.status = AlcStatus::kNoCluster;
    return false;
  }
  std::vector<TourTarget> centres;
  for (const LoopClusterId id : ids) {
    const FlownViewpoint& c = history_[clusters_[id].centre];
    centres.push_back(TourTarget{id, FlatPose{c.position_W, c.yaw_rad}});
  }
  const std::vector<LegCost> to_centres = priced(leg_costs, vehicle, centres);
  std::optional<std::size_t> best;
  for (std::size_t k = 0; k < ids.size(); ++k)
    if (to_centres[k].reachable && (!best || to_centres[k].cost_s < to_centres[*best].cost_s)) best = k;
  if (!best) {
    if (detour_) giveUp(now_s);  // the detour's cluster can no longer be reached
    d.status = AlcStatus::kNoReachableCluster;
    return false;
  }
  d.cluster = ids[*best];
  d.cluster_viewpoints = clusters_.viewpoints(history_, *d.cluster);
  d.to_cluster = to_centres[*best];
  return true;
}

AlcDecision ActiveLoopClosure::decide(const VehicleState& vehicle, double now_s, bool loop_closed,
                                      const std::vector<TourTarget>& targets, const RealCostMatrix& frontier_costs,
                                      const LegCostFunction& leg_costs, const TourResult* frontier_tour) {
  if (frontier_costs.size() != targets.size() + 1)
    throw std::invalid_argument("ActiveLoopClosure::decide: a " + std::to_string(frontier_costs.size()) +
                                "-node matrix for " + std::to_string(targets.size()) +
                                " targets (expected targets + 1)");
  if (frontier_tour && frontier_tour->order.size() != targets.size())
    throw std::invalid_argument("ActiveLoopClosure::decide: the frontier tour visits " +
                                std::to_string(frontier_tour->order.size()) + " of " + std::to_string(targets.size()) +
                                " targets");
  checkTime(now_s, "decide");
  clusters_.update(history_, now_s);

  AlcDecision d;
  d.frontier_tour = frontier_tour ? *frontier_tour : solveOpenTour(frontier_costs, params_.tour);
  d.frontier_cost_s = reachableTourCost(frontier_costs, d.frontier_tour.order, params_.unreachable_cost_s);

  const std::optional<AlcStatus> gated = gate(now_s, loop_closed);
  if (targets.empty()) {  // nothing left to explore: no detour either
    if (detour_) endDetour(now_s);
    d.status = AlcStatus::kNoFrontier;
    return d;
  }
  if (gated) {
    d.status = *gated;
    return d;
  }

  if (!chooseCluster(vehicle, now_s, params_.search_radius_m, leg_costs, d)) return d;

  // M_loop: M_frt with row 0 from c* (at rest); both tours from node 0.
  const FlownViewpoint& centre = history_[clusters_[*d.cluster].centre];
  VehicleState at_cluster;
  at_cluster.position_W = centre.position_W;
  at_cluster.yaw_rad = centre.yaw_rad;
  std::vector<double> from_cluster;
  for (const LegCost& leg : priced(leg_costs, at_cluster, targets)) from_cluster.push_back(leg.cost_s);

  d.loop_costs = loopTourMatrix(frontier_costs, from_cluster);
  d.loop_tour = solveOpenTour(d.loop_costs, params_.tour);
  d.loop_cost_s = d.to_cluster.cost_s + reachableTourCost(d.loop_costs, d.loop_tour.order, params_.unreachable_cost_s);

  if (detour_) {  // keep the detour in progress (it ends by a loop closure, a timeout or no path)
    d.status = AlcStatus::kDetour;
  } else if (d.loop_cost_s <= (1.0 + params_.epsilon) * d.frontier_cost_s) {
    detour_ = AlcDetour{*d.cluster, now_s};
    ++stats_.detours;
    d.status = AlcStatus::kDetour;
  } else {
    d.status = AlcStatus::kFrontierCheaper;
  }
  return d;
}

AlcDecision ActiveLoopClosure::decideFinish(const VehicleState& vehicle, double now_s, bool loop_closed,
                                            const LegCostFunction& leg_costs) {
  checkTime(now_s, "decideFinish");
  clusters_.update(history_, now_s);
  AlcDecision d;
  d.frontier_tour = solveOpenTour(RealCostMatrix(1), params_.tour);
  d.status = gate(now_s, loop_closed).value_or(AlcStatus::kNoFrontier);
  if (d.status != AlcStatus::kGaveUp) d.status = AlcStatus::kNoFrontier;  // the other gates guard exploring detours
  if (detour_ && !detour_->before_finish) endDetour(now_s);               // nothing left to explore
  if (!detour_) {
    const double since_loop_s = now_s - last_loop_s_.value_or(flight_start_s_);
    if (stats_.finish_detours >= std::size_t(params_.max_finish_detours) || params_.finish_loop_age_s <= 0.0 ||
        since_loop_s < params_.finish_loop_age_s)
      return d;
  }
  if (!chooseCluster(vehicle, now_s, params_.finish_search_radius_m, leg_costs, d)) return d;
  d.loop_costs = RealCostMatrix(1);
  d.loop_tour = d.frontier_tour;
  d.loop_cost_s = d.to_cluster.cost_s;
  if (!detour_) {
    detour_ = AlcDetour{*d.cluster, now_s, true};
    ++stats_.detours;
    ++stats_.finish_detours;
  }
  d.status = AlcStatus::kDetour;
  return d;
}

std::vector<std::vector<Viewpoint>> alcRefinementLayers(const VehicleState& vehicle, const AlcDecision& decision,
                                                        const std::vector<std::vector<Viewpoint>>& target_views,
                                                        const RefinementConfig& params) {
  if (target_views.size() != decision.frontier_tour.order.size())
    throw std::invalid_argument("alcRefinementLayers: viewpoints for " + std::to_string(target_views.size()) +
                                " targets, the tour has " + std::to_string(decision.frontier_tour.order.size()));
  std::vector<std::vector<Viewpoint>> tour;
  if (decision.detour()) tour.push_back(decision.cluster_viewpoints);
  for (const std::size_t i : decision.order()) tour.push_back(target_views.at(i));
  return refinementLayers(vehicle, tour, params);
}

}  // namespace vdbmap::planner
