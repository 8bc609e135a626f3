#include "vdbmap/sim/pose_graph.hpp"
#include "vdbmap/timing.hpp"

#include <ceres/ceres.h>

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

namespace vdbmap::sim {

FlatPose relativePose(const FlatPose& a, const FlatPose& b) {
  FlatPose r;
  r.position_W = Eigen::AngleAxisd(-a.yaw_rad, Vec3d::UnitZ()) * (b.position_W - a.position_W);
  r.yaw_rad = angleDifference(b.yaw_rad, a.yaw_rad);
  return r;
}

FlatPose compose(const FlatPose& a, const FlatPose& r) {
  FlatPose b;
  b.position_W = a.position_W + Eigen::AngleAxisd(a.yaw_rad, Vec3d::UnitZ()) * r.position_W;
  b.yaw_rad = a.yaw_rad + r.yaw_rad;
  return b;
}

void PoseGraphSolveConfig::validate() const {
  if (max_iterations < 1 || max_iterations > 10000)
    throw std::invalid_argument("PoseGraphSolveConfig.max_iterations must be in [1, 10000]");
  if (!(function_tolerance > 0.0 && function_tolerance < 1.0))
    throw std::invalid_argument("PoseGraphSolveConfig.function_tolerance must be in (0, 1)");
}

std::size_t PoseGraph4Dof::addNode(const FlatPose& initial) {
  if (!initial.position_W.allFinite() || !std::isfinite(initial.yaw_rad))
    throw std::invalid_argument("PoseGraph4Dof::addNode: non-finite pose for node " + std::to_string(nodes_.size()));
  nodes_.push_back(initial);
  fixed_.push_back(nodes_.size() == 1);
  return nodes_.size() - 1;
}

void PoseGraph4Dof::addEdge(const PoseGraphEdge& e) {
  const std::string name = "PoseGraph4Dof::addEdge " + std::to_string(e.from) + " -> " + std::to_string(e.to) + ": ";
  if (e.from >= nodes_.size() || e.to >= nodes_.size()) throw std::invalid_argument(name + "unknown node");
  if (e.from == e.to) throw std::invalid_argument(name + "an edge must join two different nodes");
  if (!(e.sigma_m > 0.0) || !(e.sigma_yaw_rad > 0.0)) throw std::invalid_argument(name + "sigmas must be > 0");
  if (!e.relative.position_W.allFinite() || !std::isfinite(e.relative.yaw_rad))
    throw std::invalid_argument(name + "non-finite measurement");
  edges_.push_back(e);
}

void PoseGraph4Dof::setFixed(std::size_t node, bool fixed) { fixed_.at(node) = fixed; }

void PoseGraph4Dof::setPose(std::size_t node, const FlatPose& pose) { nodes_.at(node) = pose; }

namespace {
/// The whitened residual of one edge: relative position in the from-node's yaw frame, and the
/// relative yaw wrapped to (-pi, pi].
struct EdgeResidual {
  FlatPose measured;
  double inv_sigma_m, inv_sigma_yaw;

  template <typename T>
  bool operator()(const T* a, const T* b, T* r) const {
    using std::cos;
    using std::sin;
    const T c = cos(a[3]), s = sin(a[3]);
    const T dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
    r[0] = (c * dx + s * dy - measured.position_W.x()) * inv_sigma_m;
    r[1] = (-s * dx + c * dy - measured.position_W.y()) * inv_sigma_m;
    r[2] = (dz - measured.position_W.z()) * inv_sigma_m;
    r[3] = wrap(b[3] - a[3] - measured.yaw_rad) * inv_sigma_yaw;
    return true;
  }
  template <typename T>
  static T wrap(const T& x) {
    using std::floor;
    return x - T(2.0 * M_PI) * floor((x + T(M_PI)) / T(2.0 * M_PI));
  }
};
}  // namespace

PoseGraphSummary PoseGraph4Dof::optimize(const PoseGraphSolveConfig& options) {
  options.validate();
  if (nodes_.empty()) throw std::logic_error("PoseGraph4Dof::optimize: empty graph");
  const Stopwatch solve;
  std::vector<std::array<double, 4>> x(nodes_.size());
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    x[i] = {nodes_[i].position_W.x(), nodes_[i].position_W.y(), nodes_[i].position_W.z(), nodes_[i].yaw_rad};

  ceres::Problem problem;
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    problem.AddParameterBlock(x[i].data(), 4);
    if (fixed_[i]) problem.SetParameterBlockConstant(x[i].data());
  }
  for (const PoseGraphEdge& e : edges_) {
    auto* cost = new ceres::AutoDiffCostFunction<EdgeResidual, 4, 4, 4>(
        new EdgeResidual{e.relative, 1.0 / e.sigma_m, 1.0 / e.sigma_yaw_rad});
    problem.AddResidualBlock(cost, nullptr, x[e.from].data(), x[e.to].data());
  }
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver.max_num_iterations = options.max_iterations;
  solver.function_tolerance = options.function_tolerance;
  solver.num_threads = 1;  // deterministic
  solver.logging_type = ceres::SILENT;
  std::string why;
  if (!solver.IsValid(&why)) solver.linear_solver_type = ceres::DENSE_QR;  // no sparse library in this Ceres
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);

  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    nodes_[i].position_W = Vec3d(x[i][0], x[i][1], x[i][2]);
    nodes_[i].yaw_rad = x[i][3];
  }
  PoseGraphSummary out;
  out.converged = summary.termination_type == ceres::CONVERGENCE;
  out.iterations = int(summary.iterations.size());
  out.initial_cost = summary.initial_cost;
  out.final_cost = summary.final_cost;
  out.solve_ms = solve.ms();
  return out;
}

}  // namespace vdbmap::sim
