#include "vdbmap/planner/local_refinement.hpp"
#include "vdbmap/field_check.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

namespace vdbmap::planner {

void RefinementConfig::validate() const {
  const FieldCheck check("RefinementConfig");
  if (max_clusters < 1 || max_clusters > 100) check.fail("max_clusters", "[1, 100]");
  if (!(radius_m > 0.0 && radius_m <= 1e4)) check.fail("radius_m", "(0, 1e4]");
  if (top_viewpoints < 1 || top_viewpoints > 1000) check.fail("top_viewpoints", "[1, 1000]");
  if (!(max_decay >= 0.0 && max_decay <= 1.0)) check.fail("max_decay", "[0, 1]");
  if (!(min_distance_m >= 0.0 && min_distance_m <= 1e3)) check.fail("min_distance_m", "[0, 1000]");
  if (max_planned_edges < 0 || max_planned_edges > 1000000) check.fail("max_planned_edges", "[0, 1e6]");
}

std::vector<std::vector<Viewpoint>> refinementLayers(const VehicleState& vehicle,
                                                     const std::vector<std::vector<Viewpoint>>& tour,
                                                     const RefinementConfig& params) {
  params.validate();
  std::vector<std::vector<Viewpoint>> layers;
  for (const std::vector<Viewpoint>& views : tour) {
    if (views.empty()) break;
    const Viewpoint& best = views.front();
    if (layers.size() >= 2 && (best.position_W - vehicle.position_W).norm() > params.radius_m) break;
    std::vector<Viewpoint> layer;
    for (const Viewpoint& v : views) {
      if (v.visible_samples < params.max_decay * best.visible_samples) break;  // sorted best first
      if ((v.position_W - vehicle.position_W).norm() < params.min_distance_m) continue;
      layer.push_back(v);
      if (int(layer.size()) >= params.top_viewpoints) break;
    }
    if (layer.empty()) layer.push_back(best);
    layers.push_back(std::move(layer));
    if (int(layers.size()) >= params.max_clusters) break;
  }
  if (layers.size() > 1) layers.back().resize(1);  // the anchor: the last cluster's best viewpoint
  return layers;
}

RefinementResult shortestLayeredPath(const LayeredCosts& costs) {
  RefinementResult result;
  if (costs.first.empty()) return result;
  const std::size_t layers = costs.between.size() + 1;
  std::vector<std::vector<double>> dist(layers);
  std::vector<std::vector<std::size_t>> from(layers);
  dist[0] = costs.first;
  from[0].assign(costs.first.size(), 0);
  for (std::size_t l = 0; l + 1 < layers; ++l) {
    const Eigen::MatrixXd& m = costs.between[l];
    if (std::size_t(m.rows()) != dist[l].size() || m.cols() == 0)
      throw std::invalid_argument("shortestLayeredPath: between[" + std::to_string(l) + "] is " +
                                  std::to_string(m.rows()) + " x " + std::to_string(m.cols()) + ", layer " +
                                  std::to_string(l) + " has " + std::to_string(dist[l].size()) + " viewpoints");
    dist[l + 1].assign(std::size_t(m.cols()), std::numeric_limits<double>::infinity());
    from[l + 1].assign(std::size_t(m.cols()), 0);
    for (Eigen::Index j = 0; j < m.cols(); ++j)
      for (Eigen::Index k = 0; k < m.rows(); ++k) {
        const double d = dist[l][std::size_t(k)] + m(k, j);
        if (d < dist[l + 1][std::size_t(j)]) {
          dist[l + 1][std::size_t(j)] = d;
          from[l + 1][std::size_t(j)] = std::size_t(k);
        }
      }
  }
  std::size_t j = 0;
  for (std::size_t k = 1; k < dist.back().size(); ++k)
    if (dist.back()[k] < dist.back()[j]) j = k;
  result.cost_s = dist.back()[j];
  result.choice.assign(layers, 0);
  for (std::size_t l = layers; l-- > 0;) {
    result.choice[l] = j;
    j = from[l][j];
  }
  return result;
}

namespace {
/// An edge of the layered graph: (layer of its head, tail index, head index); layer 0's tail is
/// the vehicle.
struct Edge {
  std::size_t layer, k, j;
};

/// The edge's ends (layer 0's tail is the vehicle).
std::pair<FlatPose, FlatPose> endsOf(const VehicleState& vehicle, const std::vector<std::vector<Viewpoint>>& layers,
                                     const Edge& e) {
  const FlatPose tail = e.layer == 0 ? vehicle.pose() : layers[e.layer - 1][e.k].pose();
  return {tail, layers[e.layer][e.j].pose()};
}

/// A seed from the two poses' bits: a leg's search is the same wherever its ends sit in the
/// layers, so that a cost kept from an earlier replan (LegCostCache) is the one planned now.
std::uint64_t legSeed(const FlatPose& from, const FlatPose& to) {
  std::uint64_t h = 0x9e3779b97f4a7c15ULL;
  for (const FlatPose* p : {&from, &to})
    for (const double v : {p->position_W.x(), p->position_W.y(), p->position_W.z(), p->yaw_rad}) {
      std::uint64_t bits = 0;
      std::memcpy(&bits, &v, sizeof bits);
      h = (h ^ bits) * 0xff51afd7ed558ccdULL;
      h ^= h >> 33;
    }
  return h;
}

/// The edge's cost, seeded by its ends alone: the same whichever evaluator or thread plans it.
double edgeCost(CostEvaluator& evaluator, const VehicleState& vehicle,
                const std::vector<std::vector<Viewpoint>>& layers, const Edge& e) {
  const auto [tail, head] = endsOf(vehicle, layers, e);
  const std::uint64_t seed = legSeed(tail, head);
  if (e.layer == 0) return evaluator.cost(vehicle, head, seed).cost_s;
  return evaluator.cost(tail, head, seed).cost_s;
}

/// A lower bound of the edge's cost (straightLegBound).
double edgeBound(const VehicleState& vehicle, const std::vector<std::vector<Viewpoint>>& layers, const Edge& e,
                 const CostConfig& cost) {
  const auto [tail, head] = endsOf(vehicle, layers, e);
  return straightLegBound(tail.position_W, tail.yaw_rad, head.position_W, head.yaw_rad, cost);
}

double& costOf(LayeredCosts& costs, const Edge& e) {
  return e.layer == 0 ? costs.first[e.j] : costs.between[e.layer - 1](Eigen::Index(e.k), Eigen::Index(e.j));
}

/// Every edge of the layers, layer by layer.
std::vector<Edge> allEdges(const std::vector<std::vector<Viewpoint>>& layers) {
  std::vector<Edge> edges;
  for (std::size_t j = 0; j < layers[0].size(); ++j) edges.push_back({0, 0, j});
  for (std::size_t l = 1; l < layers.size(); ++l)
    for (std::size_t k = 0; k < layers[l - 1].size(); ++k)
      for (std::size_t j = 0; j < layers[l].size(); ++j) edges.push_back({l, k, j});
  return edges;
}

LayeredCosts sizedCosts(const std::vector<std::vector<Viewpoint>>& layers) {
  LayeredCosts costs;
  costs.first.resize(layers[0].size());
  for (std::size_t l = 1; l < layers.size(); ++l)
    costs.between.emplace_back(Eigen::Index(layers[l - 1].size()), Eigen::Index(layers[l].size()));
  return costs;
}
}  // namespace

LayeredCosts layeredCosts(const MapQuery& map, const VehicleState& vehicle,
                          const std::vector<std::vector<Viewpoint>>& layers, const CostConfig& cost,
                          const PathConfig& path) {
  if (layers.empty()) return {};
  const std::vector<Edge> edges = allEdges(layers);
  std::vector<double> values(edges.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, edges.size(), 16), [&](const tbb::blocked_range<std::size_t>& r) {
    CostEvaluator evaluator(map, cost, path);
    for (std::size_t i = r.begin(); i < r.end(); ++i) values[i] = edgeCost(evaluator, vehicle, layers, edges[i]);
  });
  LayeredCosts costs = sizedCosts(layers);
  for (std::size_t i = 0; i < edges.size(); ++i) costOf(costs, edges[i]) = values[i];
  return costs;
}

RefinementResult refineLocalTour(const MapQuery& map, const VehicleState& vehicle,
                                 const std::vector<std::vector<Viewpoint>>& layers, const CostConfig& cost,
                                 const PathConfig& path, int max_planned_edges, LegCostCache* cache) {
  if (max_planned_edges < 0) throw std::invalid_argument("refineLocalTour: max_planned_edges must be >= 0");
  // Lazy shortest path (Dellin and Srinivasa, ICAPS 2016): search the layers with each edge's
  // lower bound in place of its cost, plan the edges the shortest path takes, and repeat until
  // it takes planned edges only. No other path can then be cheaper, since its cost is at least
  // its bound, so the result is layeredCosts' shortest path; most edges, those between far
  // apart viewpoints, are never planned.
  if (layers.empty()) return {};
  std::vector<std::vector<char>> planned;  // per layer, tail-major
  for (std::size_t l = 0; l < layers.size(); ++l)
    planned.emplace_back((l == 0 ? 1 : layers[l - 1].size()) * layers[l].size(), 0);
  const auto flag = [&](const Edge& e) -> char& { return planned[e.layer][e.k * layers[e.layer].size() + e.j]; };
  if (cache) {
    std::vector<FlatPose> poses;
    for (const auto& layer : layers)
      for (const Viewpoint& v : layer) poses.push_back(v.pose());
    cache->retainEndsIn(poses);
  }
  LayeredCosts costs = sizedCosts(layers);
  std::size_t reused = 0;
  for (const Edge& e : allEdges(layers)) {
    if (cache && e.layer > 0) {  // legs from the vehicle change with it: never kept
      const auto [tail, head] = endsOf(vehicle, layers, e);
      if (const std::optional<double> kept = cache->find(tail, head)) {
        costOf(costs, e) = *kept;
        flag(e) = 1;
        ++reused;
        continue;
      }
    }
    costOf(costs, e) = edgeBound(vehicle, layers, e, cost);
  }
  // One evaluator per edge of a path, kept over the rounds: each round plans at most one edge per layer.
  std::vector<std::unique_ptr<CostEvaluator>> evaluators(layers.size());
  for (std::size_t planned_edges = 0;;) {
    RefinementResult shortest = shortestLayeredPath(costs);
    shortest.planned_edges = planned_edges;
    shortest.reused_edges = reused;
    std::vector<Edge> open;
    for (std::size_t l = 0; l < layers.size(); ++l) {
      const Edge e{l, l == 0 ? 0 : shortest.choice[l - 1], shortest.choice[l]};
      if (!flag(e)) open.push_back(e);
    }
    if (open.empty() || (max_planned_edges > 0 && planned_edges >= std::size_t(max_planned_edges))) return shortest;
    planned_edges += open.size();
    tbb::parallel_for(std::size_t(0), open.size(), [&](std::size_t i) {
      if (!evaluators[i]) evaluators[i] = std::make_unique<CostEvaluator>(map, cost, path);
      costOf(costs, open[i]) = edgeCost(*evaluators[i], vehicle, layers, open[i]);
    });
    for (const Edge& e : open) {
      flag(e) = 1;
      if (cache && e.layer > 0) {
        const auto [tail, head] = endsOf(vehicle, layers, e);
        cache->insert(tail, head, costOf(costs, e));
      }
    }
  }
}

}  // namespace vdbmap::planner
