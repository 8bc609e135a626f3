// A 4-DOF pose graph (x, y, z, yaw), as VINS-Mono's loop fusion optimizes it: roll and pitch are
// observable from gravity, so only position and yaw drift and only they are corrected.
//
// Nodes are flat poses (trajectory.hpp's FlatPose). An edge i -> j measures the pose of j in i's yaw
// frame: dp = Rz(yaw_i)^T (p_j - p_i) and dyaw = yaw_j - yaw_i, with independent standard
// deviations for translation (per axis) and yaw. Optimization minimises the sum of squared
// whitened residuals with Ceres (sparse normal Cholesky, automatic derivatives), keeping the
// fixed nodes (node 0 by default) where they are.
#pragma once

#include "vdbmap/sim/trajectory.hpp"

#include <cstddef>
#include <vector>

namespace vdbmap::sim {

struct PoseGraphEdge {
  std::size_t from = 0, to = 0;
  FlatPose relative;            ///< measured pose of `to` in `from`'s yaw frame
  double sigma_m = 0.01;        ///< translation standard deviation per axis; > 0
  double sigma_yaw_rad = 0.01;  ///< > 0
};

/// The relative flat pose of b seen from a (the measurement an edge a -> b carries).
FlatPose relativePose(const FlatPose& a, const FlatPose& b);
/// a composed with the relative pose r (inverse of relativePose: compose(a, relativePose(a, b)) = b).
FlatPose compose(const FlatPose& a, const FlatPose& r);

struct PoseGraphSolveConfig {
  int max_iterations = 50;  ///< [1, 10000]
  double function_tolerance = 1e-10;
  void validate() const;
};
using PoseGraphSolveOptions [[deprecated("renamed PoseGraphSolveConfig")]] = PoseGraphSolveConfig;

struct PoseGraphSummary {
  bool converged = false;
  int iterations = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  double solve_ms = 0.0;
};

class PoseGraph4Dof {
 public:
  /// Adds a node at its initial estimate; returns its index.
  std::size_t addNode(const FlatPose& initial);
  /// Throws std::invalid_argument on an unknown node, a self edge or a sigma <= 0.
  void addEdge(const PoseGraphEdge& edge);
  /// Holds node i fixed during optimization (node 0 is fixed unless setFixed(0, false)).
  void setFixed(std::size_t node, bool fixed = true);
  /// Replaces a node's estimate (e.g. warm start from new odometry).
  void setPose(std::size_t node, const FlatPose& pose);

  std::size_t size() const { return nodes_.size(); }
  const FlatPose& pose(std::size_t node) const { return nodes_.at(node); }
  const std::vector<FlatPose>& poses() const { return nodes_; }
  const std::vector<PoseGraphEdge>& edges() const { return edges_; }

  /// Optimizes all non-fixed nodes in place. Throws std::logic_error when the graph is empty.
  PoseGraphSummary optimize(const PoseGraphSolveConfig& options = {});

 private:
  std::vector<FlatPose> nodes_;
  std::vector<bool> fixed_;
  std::vector<PoseGraphEdge> edges_;
};

}  // namespace vdbmap::sim
