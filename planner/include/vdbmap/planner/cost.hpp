// Travel costs between vehicle poses, in seconds (FUEL, Zhou et al. 2021, Eq. 5-6).
//
//   cost = max(path_length / v_max + w_dir * angle(v_now, first path direction),
//              |yaw change| / yaw_rate_max)
//
// The direction term (FUEL's ViewNode::computeCost) penalises leaving in a direction away from the
// current velocity; it applies only from the vehicle's current state (viewpoint-to-viewpoint legs
// start at rest). As in FUEL it is added to the position time inside the max. Path length is the
// straight segment when it is clear, else OMPL's (path_planner.hpp). A pair without a path gets a
// large finite cost (unreachable_cost_s), so the tour solver still returns a permutation and such
// legs come last.
#pragma once

#include "vdbmap/planner/atsp.hpp"
#include "vdbmap/planner/frontier.hpp"
#include "vdbmap/planner/path_planner.hpp"
#include "vdbmap/planner/vehicle_state.hpp"

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <utility>
#include <vector>

namespace vdbmap::planner {

struct CostConfig {
  double v_max_m_s = 2.0;            ///< (0, 100]
  double yaw_rate_max_rad_s = 0.9;   ///< (0, 100]
  /// Seconds per radian of departure away from the current velocity (FUEL's w_dir and value).
  /// Twice this turned the vehicle back less often and reached 0.95 coverage sooner at s1, but
  /// closed fewer loops at s3 with ALC (docs/exploration.md, stop 55); [0, 1e3]
  double w_dir = 1.5;
  double unreachable_cost_s = 1000.0;  ///< cost of a pair without a path; (0, 1e9]
  void validate() const;
};
using CostParams [[deprecated("renamed CostConfig")]] = CostConfig;

/// The cost formula on its own: path length, yaw change, and the angle between the current
/// velocity and the direction of departure (0 when at rest).
double motionCost(double path_length_m, double yaw_change_rad, double departure_angle_rad, const CostConfig& params);
/// A lower bound of every leg's cost between the two poses (CostEvaluator::cost, from rest or
/// moving): the straight segment at rest (no path is shorter, the direction term is not
/// negative), at most unreachable_cost_s.
double straightLegBound(const Vec3d& from_W, double from_yaw_rad, const Vec3d& to_W, double to_yaw_rad,
                        const CostConfig& params);

/// One evaluated leg.
struct LegCost {
  double cost_s = 0.0;
  bool reachable = false;
  PathResult path;
};

/// Costs of legs on one map, for one thread (it owns a PathPlanner).
class CostEvaluator {
 public:
  CostEvaluator(const MapQuery& map, const CostConfig& cost = {}, const PathConfig& path = {});

  /// From the vehicle's state (the direction term applies when it moves).
  LegCost cost(const VehicleState& from, const FlatPose& to, std::uint64_t query_seed = 0);
  /// Between two poses at rest.
  LegCost cost(const FlatPose& from, const FlatPose& to, std::uint64_t query_seed = 0);

  PathPlanner& planner() { return planner_; }
  const CostConfig& params() const { return params_; }

 private:
  CostConfig params_;
  PathPlanner planner_;
};

/// A tour target: one cluster and the pose it is visited from (usually its best viewpoint).
struct TourTarget {
  ClusterId cluster = 0;
  FlatPose pose;
};

/// Costs between the targets of the global tour, kept across replanning: FUEL recomputes only the
/// pairs that involve new clusters. update() drops pairs of targets that are gone, and computes
/// the missing ones (or those whose pose moved) in parallel, one CostEvaluator per task, each leg
/// seeded by its cluster ids so that the result depends neither on the thread count nor on the
/// update that plans it. Legs between targets are symmetric (both at rest), so each pair is
/// planned once.
class PairCostTable {
 public:
  explicit PairCostTable(const CostConfig& cost = {}, const PathConfig& path = {});

  /// Plans the missing pairs (of new targets, of targets whose pose moved, and estimates left by
  /// an earlier update) and returns how many it planned. With `max_planned` > 0 it plans at most
  /// that many, shortest straight leg first; each other missing pair holds the straight leg's
  /// cost, a lower bound, until a later update plans it. That bounds the time of one update when
  /// many clusters change at once.
  std::size_t update(const MapQuery& map, const std::vector<TourTarget>& targets, std::size_t max_planned = 0);
  /// The cost from one target to another (0 for a == b); throws std::out_of_range for a pair that
  /// update() has not seen.
  double cost(ClusterId from, ClusterId to) const;
  /// False for a pair without a path; true for an estimate (not planned yet).
  bool reachable(ClusterId from, ClusterId to) const;
  std::size_t pairCount() const { return pairs_.size(); }
  /// Pairs that hold an estimate, to be planned by a later update.
  std::size_t estimatedCount() const;
  const CostConfig& costParams() const { return cost_; }
  const PathConfig& pathParams() const { return path_; }

 private:
  struct Entry {
    double cost_s = 0.0;
    bool reachable = false;
    bool planned = true;  ///< false: the straight leg's estimate
  };
  CostConfig cost_;
  PathConfig path_;
  std::map<ClusterId, FlatPose> poses_;
  std::map<std::pair<ClusterId, ClusterId>, Entry> pairs_;  ///< key (low id, high id)
};

/// Costs of legs between two poses at rest, kept from one replan to the next under their exact
/// poses (local refinement's edges between viewpoints, which mostly stay where they were: a
/// cluster's viewpoints change only when the cluster does). Like PairCostTable, a leg is planned
/// again when one of its ends moves, not when the map grows around it; the flight itself is
/// always planned afresh on the map of the moment.
class LegCostCache {
 public:
  /// The cost stored for the leg from `from` to `to` (ordered), if any.
  std::optional<double> find(const FlatPose& from, const FlatPose& to) const;
  void insert(const FlatPose& from, const FlatPose& to, double cost_s);
  /// Forgets every leg with an end that is not one of `poses`.
  void retainEndsIn(const std::vector<FlatPose>& poses);
  std::size_t size() const { return costs_.size(); }

 private:
  using PoseKey = std::array<double, 4>;    ///< x, y, z, yaw
  using Key = std::pair<PoseKey, PoseKey>;  ///< from, to
  static PoseKey poseKey(const FlatPose& pose);
  std::map<Key, double> costs_;
};

/// The open-tour matrix for the ATSP solver: node 0 is the vehicle, node i + 1 is targets[i].
/// Row 0 holds the costs from the vehicle's state (`from_vehicle[i]`), column 0 is zero (the tour
/// does not return), the rest comes from the table. Solve it with AtspConfig::open_from = 0.
RealCostMatrix buildTourCostMatrix(const std::vector<double>& from_vehicle, const std::vector<TourTarget>& targets,
                                   const PairCostTable& table);

/// Costs from the vehicle to every target (in parallel, seeded by cluster id).
std::vector<LegCost> costsFromVehicle(const MapQuery& map, const VehicleState& vehicle,
                                      const std::vector<TourTarget>& targets, const CostConfig& cost = {},
                                      const PathConfig& path = {});

}  // namespace vdbmap::planner
