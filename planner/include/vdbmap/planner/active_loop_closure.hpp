// Active loop closure, ALC (Zhang et al. 2022, Sect. IV-D, Algorithm 2 with the text's semantics):
// at a global replan, a tour that first visits a nearby loop-closing cluster is taken when it
// costs at most (1 + epsilon) times the plain frontier tour.
//
// At each global replan, with the frontier tour's matrix M_frt (buildTourCostMatrix: node 0 the
// vehicle, node i + 1 frontier target i):
//   1. candidates: loop clusters with a viewpoint within search_radius_m of the vehicle;
//   2. c* = the candidate whose centre is cheapest to reach from the vehicle's current state
//      (CostEvaluator legs: real paths, the velocity-direction term; ties: the older cluster);
//   3. M_loop = M_frt with row 0 replaced by the costs from c*'s centre (at rest) to the targets;
//      no other cost is computed again;
//   4. both open tours from node 0 are solved (solveOpenTour, i.e. solveAtsp open_from = 0);
//   5. C_frt = the frontier tour's cost; C_loop = cost(vehicle -> c*) + the tour's cost from c*;
//   6. the detour via c* is taken iff C_loop <= (1 + epsilon) C_frt.
// (The paper's Algorithm 2 prints the comparison inverted; its text and DESIGN.md 1.5 rule.)
// Legs at or above unreachable_cost_s (targets without a path, which both tours leave for last)
// are left out of C_frt and C_loop so that they do not inflate the epsilon allowance.
//
// Never stall: a detour, once taken, is kept (same cluster, tours recomputed at every replan, the
// vehicle trying the cluster's viewpoints through local refinement) until a loop closure is
// detected, or give_up_timeout_s passes without one, or the cluster can no longer be reached.
// Giving up suspends ALC for suspension_s; a cluster given up on max_failures_per_cluster times is
// never chosen again. There is no ALC during the first initial_period_s of a flight, nor within
// loop_quiet_s after any detected loop closure (drift was just corrected).
//
// Beyond the paper, a loop before finishing (decideFinish): when exploration would end and no loop
// closed for finish_loop_age_s, one more detour goes to the cheapest loop cluster within
// finish_search_radius_m, so that the drift of the last stretch is corrected before the map is
// handed over (the frames since the last loop closure are otherwise left where drift put them).
// It ends like any detour: a loop closure, the give-up timeout or no path. A loop's correction
// can open new frontiers, and their exploration drifts again: at most max_finish_detours per flight.
//
// Defaults follow the authors' code and simulation launch file
// (github.com/yzhangec/Exploration-with-Global-Consistency):
//   give_up_timeout_s  15 s  their alc_max_duration: time in a loop cluster without a loop
//                            (their real-robot launch file sets 30 s);
//   loop_quiet_s       30 s  their loop_max_duration: no ALC clusters for 30 s after a loop (45 s);
//   initial_period_s   20 s  no ALC in the first 20 s after exploration starts;
//   suspension_s       10 s  after giving up, ALC is off for 10 s (hard-coded there);
//   search_radius_m     3 m  their KD-tree radius around the vehicle;
//   epsilon           0.2    their alc_cost_scale = 1.2 in both launch files.
#pragma once

#include "vdbmap/planner/cost.hpp"
#include "vdbmap/planner/local_refinement.hpp"
#include "vdbmap/planner/loop_clusters.hpp"
#include "vdbmap/planner/tour.hpp"
#include "vdbmap/planner/viewpoint_history.hpp"

#include <cstddef>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace vdbmap::planner {

struct AlcConfig {
  ViewpointHistoryConfig history;
  LoopClusterConfig clusters;
  double epsilon = 0.2;              ///< detour iff C_loop <= (1 + epsilon) C_frt; [0, 100]
  double search_radius_m = 3.0;      ///< candidate clusters have a viewpoint this close; (0, 1e3]
  double initial_period_s = 20.0;    ///< no ALC in the first seconds of a flight; [0, 1e6]
  double give_up_timeout_s = 15.0;   ///< a detour without a loop closure ends after this; (0, 1e6]
  double suspension_s = 10.0;        ///< ALC is off this long after giving up; [0, 1e6]
  double loop_quiet_s = 30.0;        ///< ALC is off this long after any loop closure; [0, 1e6]
  int max_failures_per_cluster = 2;  ///< given up this often, a cluster is never chosen again; [1, 1000]
  /// A detour before finishing when the last loop closure (or the flight's start) is at least this
  /// old; 0: finish without one; [0, 1e6]
  double finish_loop_age_s = 10.0;
  double finish_search_radius_m = 10.0;  ///< its candidate clusters have a viewpoint this close; (0, 1e3]
  int max_finish_detours = 3;            ///< detours before finishing per flight; [1, 100]
  /// Legs costing this much or more mean "no path" (keep equal to CostConfig::unreachable_cost_s);
  /// (0, 1e9]
  double unreachable_cost_s = 1000.0;
  TourConfig tour;  ///< the solver's budget and seed for both tours
  void validate() const;
};
using AlcParams [[deprecated("renamed AlcConfig")]] = AlcConfig;

/// Why the decision came out as it did. Every status is an expected outcome.
enum class AlcStatus {
  kDetour,              ///< fly via the loop cluster first (a new detour, or the one in progress)
  kFrontierCheaper,     ///< compared: C_loop > (1 + epsilon) C_frt, the frontier tour is kept
  kNoFrontier,          ///< no frontier target: nothing to compare (exploration is over, no loop needed before)
  kInitialPeriod,       ///< within initial_period_s of the flight's start
  kQuietAfterLoop,      ///< within loop_quiet_s of a detected loop closure (also: a detour just succeeded)
  kGaveUp,              ///< the detour in progress timed out (or its cluster became unreachable) now
  kSuspended,           ///< within suspension_s of giving up
  kNoCluster,           ///< no usable loop cluster within search_radius_m
  kNoReachableCluster,  ///< candidates, but no path to any of them
};

std::string toString(AlcStatus status);

/// Prices legs from one state to several poses: the costs ALC needs beyond M_frt (vehicle ->
/// cluster centres, and cluster centre at rest -> frontier targets).
using LegCostFunction =
    std::function<std::vector<LegCost>(const VehicleState& from, const std::vector<TourTarget>& to)>;

/// The planner's legs on a map: costsFromVehicle (CostEvaluator: straight or OMPL paths, FUEL's
/// cost), in parallel. The function keeps a reference to `map`: use it while the map lives.
LegCostFunction mapLegCosts(const MapQuery& map, const CostConfig& cost = {}, const PathConfig& path = {});
/// The same with the pair table's cost and path parameters, so that ALC's legs match M_frt's.
LegCostFunction mapLegCosts(const MapQuery& map, const PairCostTable& table);

/// M_loop: M_frt with row 0 replaced by `from_cluster` (costs from the loop cluster to each
/// target); column 0 stays zero. Throws std::invalid_argument when the sizes do not fit.
RealCostMatrix loopTourMatrix(const RealCostMatrix& frontier_costs, const std::vector<double>& from_cluster);

/// An open tour's cost over legs below `unreachable_cost_s` (legs at or above it are skipped).
double reachableTourCost(const RealCostMatrix& costs, const std::vector<std::size_t>& order, double unreachable_cost_s);

struct AlcDecision {
  AlcStatus status = AlcStatus::kNoFrontier;
  bool detour() const { return status == AlcStatus::kDetour; }

  TourResult frontier_tour;      ///< over M_frt (solved here, or the one passed in)
  double frontier_cost_s = 0.0;  ///< C_frt

  // Set when a loop cluster was evaluated (status kDetour or kFrontierCheaper):
  std::optional<LoopClusterId> cluster;       ///< c*
  std::vector<Viewpoint> cluster_viewpoints;  ///< c*'s viewpoints, its centre first (for local refinement)
  LegCost to_cluster;                         ///< vehicle -> c*'s centre, with its path
  RealCostMatrix loop_costs;                  ///< M_loop
  TourResult loop_tour;                       ///< over M_loop: the frontier targets after c*
  double loop_cost_s = 0.0;                   ///< C_loop = to_cluster.cost_s + the tour's cost from c*

  /// The frontier targets in the order to fly them: the loop tour's after a detour, else the
  /// frontier tour's.
  const std::vector<std::size_t>& order() const { return detour() ? loop_tour.order : frontier_tour.order; }
};

/// Counters for summaries.
struct AlcStats {
  std::size_t detours = 0;          ///< detours started
  std::size_t loops_on_detour = 0;  ///< detours ended by a loop closure
  std::size_t give_ups = 0;         ///< detours given up (timeout or unreachable)
  std::size_t finish_detours = 0;   ///< detours before finishing (also counted in detours)
  double detour_time_s = 0.0;       ///< time spent on detours (the one in progress up to now)
};

/// The detour in progress.
struct AlcDetour {
  LoopClusterId cluster = 0;
  double since_s = 0.0;
  bool before_finish = false;  ///< started by decideFinish
};

class ActiveLoopClosure {
 public:
  /// `flight_start_s`: when the flight (exploration) started, for initial_period_s.
  explicit ActiveLoopClosure(const AlcConfig& params = {}, double flight_start_s = 0.0);

  /// Feeds the vehicle's pose as it flies (every cycle is fine: the history thins it). Returns
  /// true when it was recorded. Throws std::invalid_argument for stamps going back in time.
  bool addFlownPose(const Vec3d& position_W, double yaw_rad, double stamp_s);

  /// After a pose-graph correction: moves the recorded viewpoints (see ViewpointHistory::correct)
  /// and the clusters' centres with them.
  void correctHistory(const std::function<FlatPose(const FlownViewpoint&)>& corrected);

  /// The decision at a global replan. `targets` and `frontier_costs` are the frontier tour's
  /// (frontier_costs = buildTourCostMatrix(costs from `vehicle`, targets, table)); `frontier_tour`
  /// is its solved tour if the caller has one (else it is solved here). `loop_closed`: a loop
  /// closure was detected since the previous call. Throws std::invalid_argument when the sizes
  /// do not fit or now_s goes back in time.
  AlcDecision decide(const VehicleState& vehicle, double now_s, bool loop_closed,
                     const std::vector<TourTarget>& targets, const RealCostMatrix& frontier_costs,
                     const LegCostFunction& leg_costs, const TourResult* frontier_tour = nullptr);

  /// The decision when there is no frontier target left and the flight is over (or a detour is in
  /// progress): a detour before finishing (status kDetour; `cluster_viewpoints` to try, its centre
  /// first), or finish (any other status). An exploring detour in progress ends here; a detour
  /// before finishing goes on; one given up now is followed by the next at once, if one is due. Throws
  /// std::invalid_argument when now_s goes back in time.
  AlcDecision decideFinish(const VehicleState& vehicle, double now_s, bool loop_closed,
                           const LegCostFunction& leg_costs);

  /// True when a detour is in progress and its timeout has passed: the replanning loop should
  /// replan now (decide() will give up), rather than at its next periodic replan.
  bool detourTimedOut(double now_s) const;

  const std::optional<AlcDetour>& detour() const { return detour_; }
  /// ALC stays off until then after giving up (none if it never gave up).
  std::optional<double> suspendedUntil() const { return suspended_until_s_; }
  /// Times a cluster was given up on.
  std::size_t failures(LoopClusterId id) const;
  AlcStats stats(double now_s) const;

  const ViewpointHistory& history() const { return history_; }
  const LoopClusters& clusters() const { return clusters_; }
  const AlcConfig& params() const { return params_; }

 private:
  /// The gates before any cost is computed (loop closures and timeouts included).
  std::optional<AlcStatus> gate(double now_s, bool loop_closed);
  void endDetour(double now_s);
  void giveUp(double now_s);
  void checkTime(double now_s, const char* who);
  std::vector<LoopClusterId> candidates(const Vec3d& position_W, double radius_m) const;
  /// c*: of the usable clusters with a viewpoint within radius_m (the detour's own while one is in
  /// progress), the one whose centre is cheapest to reach from `vehicle` (ties: the older
  /// cluster). Sets d.cluster, d.cluster_viewpoints and d.to_cluster and returns true; else sets
  /// d.status to kNoCluster or kNoReachableCluster, giving up a detour whose cluster can no longer
  /// be reached.
  bool chooseCluster(const VehicleState& vehicle, double now_s, double radius_m, const LegCostFunction& leg_costs,
                     AlcDecision& d);

  AlcConfig params_;
  double flight_start_s_;
  ViewpointHistory history_;
  LoopClusters clusters_;
  std::optional<AlcDetour> detour_;
  std::optional<double> suspended_until_s_;
  std::optional<double> last_loop_s_;
  std::optional<double> last_decision_s_;
  std::map<LoopClusterId, std::size_t> failures_;
  AlcStats stats_;
};

/// Layers for refineLocalTour (refinementLayers): on a detour the loop cluster's viewpoints come
/// first, then the frontier clusters in the loop tour's order; otherwise the frontier tour's.
/// `target_views[i]` holds frontier target i's viewpoints, best first.
std::vector<std::vector<Viewpoint>> alcRefinementLayers(const VehicleState& vehicle, const AlcDecision& decision,
                                                        const std::vector<std::vector<Viewpoint>>& target_views,
                                                        const RefinementConfig& params = {});

}  // namespace vdbmap::planner
