// Local refinement of the global tour (FUEL, Zhou et al. 2021, Sect. V-C).
//
// The global tour visits each cluster's single best viewpoint. Near the vehicle, FUEL looks again:
// the next few clusters of the tour (refinementLayers) each contribute their top viewpoints as one
// layer of a graph; edges join every viewpoint of a layer to every viewpoint of the next (the first
// layer to the vehicle's state, with the velocity-direction term); the last layer keeps only its
// best viewpoint, anchoring the rest of the tour. The cheapest path through the layers is found by
// dynamic programming (the graph is a layered DAG: Dijkstra and DP give the same path), and the
// vehicle flies to the viewpoint it picks in the first layer.
#pragma once

#include "vdbmap/planner/cost.hpp"
#include "vdbmap/planner/viewpoint.hpp"

#include <Eigen/Core>

#include <vector>

namespace vdbmap::planner {

struct RefinementConfig {
  int max_clusters = 7;           ///< FUEL refined_num: clusters of the tour refined; [1, 100]
  /// FUEL refined_radius: after the first two, stop at a cluster whose best viewpoint is farther
  /// than this from the vehicle; (0, 1e4]
  double radius_m = 5.0;
  int top_viewpoints = 15;        ///< FUEL top_view_num: viewpoints per layer; [1, 1000]
  /// FUEL max_decay: a layer keeps viewpoints seeing at least this fraction of its best's samples; [0, 1]
  double max_decay = 0.8;
  /// FUEL min_candidate_dist: viewpoints closer than this to the vehicle are skipped (unless that
  /// would leave the layer empty: then the best one is kept); [0, 1e3]
  double min_distance_m = 0.75;
  /// Edges refineLocalTour plans at most (0 = as many as its lazy search needs); the search stops
  /// after the round that reaches it, and the path is then shortest with the unplanned edges at
  /// their bound. Bounds a replan where many straight legs are blocked (each an OMPL search, up to
  /// 4 ms when it finds no path); [0, 1e6]
  int max_planned_edges = 64;

  void validate() const;
};
using RefinementParams [[deprecated("renamed RefinementConfig")]] = RefinementConfig;

/// The layers for refinement: `tour` lists, in tour order, each cluster's viewpoints (best first,
/// as computeViewpoints returns them). Layers follow the tour for at most max_clusters clusters
/// (always at least two when the tour has them); the last layer holds only its best viewpoint.
/// Clusters with no viewpoints end the layers.
std::vector<std::vector<Viewpoint>> refinementLayers(const VehicleState& vehicle,
                                                     const std::vector<std::vector<Viewpoint>>& tour,
                                                     const RefinementConfig& params = {});

/// Edge costs of the layered graph: first[j] from the vehicle to layer 0's viewpoint j;
/// between[l](k, j) from layer l's viewpoint k to layer l+1's viewpoint j.
struct LayeredCosts {
  std::vector<double> first;
  std::vector<Eigen::MatrixXd> between;
};

struct RefinementResult {
  std::vector<std::size_t> choice;  ///< per layer, the index of the chosen viewpoint
  double cost_s = 0.0;              ///< sum of the chosen edges
  std::size_t planned_edges = 0;    ///< edges refineLocalTour planned (0 from shortestLayeredPath)
  std::size_t reused_edges = 0;     ///< edges whose cost refineLocalTour took from its LegCostCache
};

/// The cheapest path through the layers (ties: the lower index). Empty when there are no layers.
/// Throws std::invalid_argument when the sizes do not fit together.
RefinementResult shortestLayeredPath(const LayeredCosts& costs);

/// Edge costs by CostEvaluator (paths on the map), computed in parallel. Each edge's search is
/// seeded by its two poses, so its cost does not depend on where they sit in the layers.
LayeredCosts layeredCosts(const MapQuery& map, const VehicleState& vehicle,
                          const std::vector<std::vector<Viewpoint>>& layers, const CostConfig& cost = {},
                          const PathConfig& path = {});

/// The result of shortestLayeredPath(layeredCosts(...)) (ties aside), planning only the edges a
/// lazy search needs: those of paths that are shortest when unplanned edges count at their
/// straight leg's cost, a lower bound. With max_planned_edges > 0, see RefinementConfig.
///
/// With a `cache`, an edge between viewpoints that it holds is not planned again (its cost is the
/// one planned on the map of that earlier call), the edges planned here are added, and the cache
/// keeps only legs between this call's viewpoints. Edges from the vehicle are always planned. The
/// manager keeps one cache over its replans: consecutive replans mostly refine the same clusters'
/// viewpoints.
RefinementResult refineLocalTour(const MapQuery& map, const VehicleState& vehicle,
                                 const std::vector<std::vector<Viewpoint>>& layers, const CostConfig& cost = {},
                                 const PathConfig& path = {}, int max_planned_edges = 0, LegCostCache* cache = nullptr);

}  // namespace vdbmap::planner
