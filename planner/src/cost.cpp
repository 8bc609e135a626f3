#include "vdbmap/planner/cost.hpp"
#include "vdbmap/field_check.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>
#include <string>

namespace vdbmap::planner {

namespace {
constexpr double kMovingSpeed_m_s = 1e-3;  ///< below this the vehicle counts as at rest (FUEL's test)

std::uint64_t pairSeed(ClusterId a, ClusterId b) { return (std::uint64_t(a) << 32) ^ std::uint64_t(b) ^ 0x5bd1e995ULL; }
}  // namespace

void CostConfig::validate() const {
  const FieldCheck check("CostConfig");
  if (!(v_max_m_s > 0.0 && v_max_m_s <= 100.0)) check.fail("v_max_m_s", "(0, 100]");
  if (!(yaw_rate_max_rad_s > 0.0 && yaw_rate_max_rad_s <= 100.0)) check.fail("yaw_rate_max_rad_s", "(0, 100]");
  if (!(w_dir >= 0.0 && w_dir <= 1e3)) check.fail("w_dir", "[0, 1000]");
  if (!(unreachable_cost_s > 0.0 && unreachable_cost_s <= 1e9)) check.fail("unreachable_cost_s", "(0, 1e9]");
}

double motionCost(double path_length_m, double yaw_change_rad, double departure_angle_rad, const CostConfig& p) {
  const double position_s = path_length_m / p.v_max_m_s + p.w_dir * departure_angle_rad;
  const double yaw_s = std::abs(yaw_change_rad) / p.yaw_rate_max_rad_s;
  return std::max(position_s, yaw_s);
}

double straightLegBound(const Vec3d& from_W, double from_yaw_rad, const Vec3d& to_W, double to_yaw_rad,
                        const CostConfig& p) {
  return std::min(motionCost((to_W - from_W).norm(), yawDistance(from_yaw_rad, to_yaw_rad), 0.0, p),
                  p.unreachable_cost_s);
}

CostEvaluator::CostEvaluator(const MapQuery& map, const CostConfig& cost, const PathConfig& path)
    : params_(cost), planner_(map, path) {
  params_.validate();
}

LegCost CostEvaluator::cost(const VehicleState& from, const FlatPose& to, std::uint64_t query_seed) {
  LegCost leg;
  leg.path = planner_.plan(from.position_W, to.position_W, query_seed);
  leg.reachable = leg.path.ok();
  if (!leg.reachable) {
    leg.cost_s = params_.unreachable_cost_s;
    return leg;
  }
  double departure = 0.0;
  if (from.velocity_W.norm() > kMovingSpeed_m_s && leg.path.waypoints.size() >= 2) {
    const Vec3d dir = leg.path.waypoints[1] - leg.path.waypoints[0];
    if (dir.norm() > 1e-9)
      departure = std::acos(std::clamp(from.velocity_W.normalized().dot(dir.normalized()), -1.0, 1.0));
  }
  leg.cost_s = motionCost(leg.path.length_m, yawDistance(from.yaw_rad, to.yaw_rad), departure, params_);
  return leg;
}

LegCost CostEvaluator::cost(const FlatPose& from, const FlatPose& to, std::uint64_t query_seed) {
  VehicleState rest;
  rest.position_W = from.position_W;
  rest.yaw_rad = from.yaw_rad;
  return cost(rest, to, query_seed);
}

PairCostTable::PairCostTable(const CostConfig& cost, const PathConfig& path) : cost_(cost), path_(path) {
  cost_.validate();
  path_.validate();
}

std::size_t PairCostTable::update(const MapQuery& map, const std::vector<TourTarget>& targets,
                                  std::size_t max_planned) {
  // Forget targets that are gone or whose pose changed.
  std::map<ClusterId, FlatPose> now;
  for (const TourTarget& t : targets) now[t.cluster] = t.pose;
  auto same = [](const FlatPose& a, const FlatPose& b) {
    return a.position_W == b.position_W && a.yaw_rad == b.yaw_rad;
  };
  for (auto it = pairs_.begin(); it != pairs_.end();) {
    const auto a = now.find(it->first.first), b = now.find(it->first.second);
    const bool keep = a != now.end() && b != now.end() && same(a->second, poses_.at(a->first)) &&
                      same(b->second, poses_.at(b->first));
    it = keep ? std::next(it) : pairs_.erase(it);
  }
  poses_ = now;

  std::vector<std::pair<ClusterId, ClusterId>> missing;
  for (auto a = now.begin(); a != now.end(); ++a)
    for (auto b = std::next(a); b != now.end(); ++b) {
      const auto it = pairs_.find({a->first, b->first});
      if (it == pairs_.end() || !it->second.planned) missing.emplace_back(a->first, b->first);
    }
  if (max_planned > 0 && missing.size() > max_planned) {
    // The tour's legs join near targets: plan the shortest straight legs now, estimate the rest.
    std::vector<std::pair<double, std::pair<ClusterId, ClusterId>>> by_cost;
    for (const auto& ab : missing) {
      const FlatPose &a = now.at(ab.first), &b = now.at(ab.second);
      by_cost.emplace_back(straightLegBound(a.position_W, a.yaw_rad, b.position_W, b.yaw_rad, cost_), ab);
    }
    std::sort(by_cost.begin(), by_cost.end());  // ties by ids: the same choice on every machine
    missing.clear();
    for (std::size_t i = 0; i < by_cost.size(); ++i) {
      if (i < max_planned)
        missing.push_back(by_cost[i].second);
      else
        pairs_[by_cost[i].second] = Entry{by_cost[i].first, true, false};
    }
  }

  std::vector<Entry> results(missing.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, missing.size(), 8), [&](const tbb::blocked_range<std::size_t>& r) {
    CostEvaluator evaluator(map, cost_, path_);
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      const auto [a, b] = missing[i];
      const LegCost leg = evaluator.cost(now.at(a), now.at(b), pairSeed(a, b));
      results[i] = Entry{leg.cost_s, leg.reachable};
    }
  });
  for (std::size_t i = 0; i < missing.size(); ++i) pairs_[missing[i]] = results[i];
  return missing.size();
}

std::size_t PairCostTable::estimatedCount() const {
  return std::size_t(std::count_if(pairs_.begin(), pairs_.end(), [](const auto& p) { return !p.second.planned; }));
}

double PairCostTable::cost(ClusterId from, ClusterId to) const {
  if (from == to) return 0.0;
  return pairs_.at({std::min(from, to), std::max(from, to)}).cost_s;
}

bool PairCostTable::reachable(ClusterId from, ClusterId to) const {
  if (from == to) return true;
  return pairs_.at({std::min(from, to), std::max(from, to)}).reachable;
}

LegCostCache::PoseKey LegCostCache::poseKey(const FlatPose& pose) {
  return {pose.position_W.x(), pose.position_W.y(), pose.position_W.z(), pose.yaw_rad};
}

std::optional<double> LegCostCache::find(const FlatPose& from, const FlatPose& to) const {
  const auto it = costs_.find({poseKey(from), poseKey(to)});
  if (it == costs_.end()) return std::nullopt;
  return it->second;
}

void LegCostCache::insert(const FlatPose& from, const FlatPose& to, double cost_s) {
  costs_[{poseKey(from), poseKey(to)}] = cost_s;
}

void LegCostCache::retainEndsIn(const std::vector<FlatPose>& poses) {
  std::set<PoseKey> kept;
  for (const FlatPose& p : poses) kept.insert(poseKey(p));
  for (auto it = costs_.begin(); it != costs_.end();) {
    const bool keep = kept.count(it->first.first) && kept.count(it->first.second);
    it = keep ? std::next(it) : costs_.erase(it);
  }
}

RealCostMatrix buildTourCostMatrix(const std::vector<double>& from_vehicle, const std::vector<TourTarget>& targets,
                                   const PairCostTable& table) {
  if (from_vehicle.size() != targets.size())
    throw std::invalid_argument("buildTourCostMatrix: from_vehicle has " + std::to_string(from_vehicle.size()) +
                                " costs for " + std::to_string(targets.size()) + " targets");
  const std::size_t n = targets.size() + 1;
  RealCostMatrix m(n, 0.0);
  for (std::size_t j = 0; j < targets.size(); ++j) m(0, j + 1) = from_vehicle[j];
  for (std::size_t i = 0; i < targets.size(); ++i)
    for (std::size_t j = 0; j < targets.size(); ++j)
      m(i + 1, j + 1) = i == j ? 0.0 : table.cost(targets[i].cluster, targets[j].cluster);
  // Column 0 stays zero: returning to the vehicle is free, which makes the closed tour an open path.
  return m;
}

std::vector<LegCost> costsFromVehicle(const MapQuery& map, const VehicleState& vehicle,
                                      const std::vector<TourTarget>& targets, const CostConfig& cost,
                                      const PathConfig& path) {
  std::vector<LegCost> legs(targets.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, targets.size(), 4), [&](const tbb::blocked_range<std::size_t>& r) {
    CostEvaluator evaluator(map, cost, path);
    for (std::size_t i = r.begin(); i < r.end(); ++i)
      legs[i] = evaluator.cost(vehicle, targets[i].pose, pairSeed(0, targets[i].cluster));
  });
  return legs;
}

}  // namespace vdbmap::planner
