#include "vdbmap/planner/local_refinement.hpp"
#include "vdbmap/field_check.hpp"

#include <tbb/parallel_for.h>

#include <limits>
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

LayeredCosts layeredCosts(const MapQuery& map, const VehicleState& vehicle,
                          const std::vector<std::vector<Viewpoint>>& layers, const CostConfig& cost,
                          const PathConfig& path) {
  LayeredCosts costs;
  if (layers.empty()) return costs;
  // Every edge as one job: (layer of its head, tail index, head index); layer 0's tail is the vehicle.
  struct Edge {
    std::size_t layer, k, j;
  };
  std::vector<Edge> edges;
  for (std::size_t j = 0; j < layers[0].size(); ++j) edges.push_back({0, 0, j});
  for (std::size_t l = 1; l < layers.size(); ++l)
    for (std::size_t k = 0; k < layers[l - 1].size(); ++k)
      for (std::size_t j = 0; j < layers[l].size(); ++j) edges.push_back({l, k, j});
  std::vector<double> values(edges.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, edges.size(), 16), [&](const tbb::blocked_range<std::size_t>& r) {
    CostEvaluator evaluator(map, cost, path);
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      const Edge& e = edges[i];
      const Viewpoint& head = layers[e.layer][e.j];
      const FlatPose to{head.position_W, head.yaw_rad};
      const std::uint64_t seed = (std::uint64_t(e.layer) << 40) ^ (std::uint64_t(e.k) << 20) ^ e.j;
      if (e.layer == 0) {
        values[i] = evaluator.cost(vehicle, to, seed).cost_s;
      } else {
        const Viewpoint& tail = layers[e.layer - 1][e.k];
        values[i] = evaluator.cost(FlatPose{tail.position_W, tail.yaw_rad}, to, seed).cost_s;
      }
    }
  });
  costs.first.resize(layers[0].size());
  for (std::size_t l = 1; l < layers.size(); ++l)
    costs.between.emplace_back(Eigen::Index(layers[l - 1].size()), Eigen::Index(layers[l].size()));
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const Edge& e = edges[i];
    if (e.layer == 0)
      costs.first[e.j] = values[i];
    else
      costs.between[e.layer - 1](Eigen::Index(e.k), Eigen::Index(e.j)) = values[i];
  }
  return costs;
}

RefinementResult refineLocalTour(const MapQuery& map, const VehicleState& vehicle,
                                 const std::vector<std::vector<Viewpoint>>& layers, const CostConfig& cost,
                                 const PathConfig& path) {
  return shortestLayeredPath(layeredCosts(map, vehicle, layers, cost, path));
}

}  // namespace vdbmap::planner
