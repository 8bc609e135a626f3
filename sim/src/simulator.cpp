#include "vdbmap/sim/simulator.hpp"

#include "vdbmap/camera.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace vdbmap::sim {

const char* toString(LoopClosureMode mode) {
  switch (mode) {
    case LoopClosureMode::Off:
      return "off";
    case LoopClosureMode::PoseGraph:
      return "pgo";
    case LoopClosureMode::Perfect:
      return "perfect";
  }
  return "?";
}

LoopClosureMode parseLoopClosureMode(const std::string& text) {
  if (text == "off") return LoopClosureMode::Off;
  if (text == "pgo") return LoopClosureMode::PoseGraph;
  if (text == "perfect") return LoopClosureMode::Perfect;
  throw std::invalid_argument("loop closure must be off, pgo or perfect, got '" + text + "'");
}

void SimulatorConfig::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("SimulatorConfig." + what); };
  camera.validate();
  drift.validate();
  loop.validate();
  solve.validate();
  if (!(std::abs(camera_pitch_rad) <= M_PI / 2)) fail("camera_pitch_rad must be in [-pi/2, pi/2]");
  if (!(loop_sigma_m >= 0.0 && loop_sigma_m <= 1.0)) fail("loop_sigma_m must be in [0, 1]");
  if (!(loop_sigma_yaw_rad >= 0.0 && loop_sigma_yaw_rad <= 0.5)) fail("loop_sigma_yaw_rad must be in [0, 0.5]");
  if (!(odometry_sigma_floor >= 1e-9 && odometry_sigma_floor <= 1.0)) fail("odometry_sigma_floor must be in [1e-9, 1]");
}

namespace {
/// The 4-DOF transform C with C o b = a (b's frame re-anchored onto a).
FlatPose anchorOnto(const FlatPose& a, const FlatPose& b) {
  FlatPose c;
  c.yaw_rad = a.yaw_rad - b.yaw_rad;
  c.position_W = a.position_W - Eigen::AngleAxisd(c.yaw_rad, Vec3d::UnitZ()) * b.position_W;
  return c;
}
}  // namespace

Simulator::Simulator(const World& world, const SimulatorConfig& config, const FlatPose& start, double t0_s)
    : world_(world),
      config_(config),
      camera_(config.camera),
      T_B_S_(lookingPose(Vec3d::Zero(), 0.0, config.camera_pitch_rad)),
      odometry_(config.drift, start, t0_s),
      detector_(config.loop),
      loop_noise_rng_(config.drift.seed ^ 0x5eed100bULL),
      t0_(t0_s),
      truth_(start) {
  config_.validate();
}

void Simulator::advance(double t_s, const FlatPose& truth) {
  odometry_.advance(t_s, truth);
  truth_ = truth;
}

FlatPose Simulator::bodyEstimate() const { return compose(anchor_, odometry_.pose()); }

Pose3d Simulator::sensorPose(const FlatPose& body) const { return bodyPose(body) * T_B_S_; }

SimFrame Simulator::capture() {
  const double t = odometry_.time();
  if (!frames_t_.empty() && t <= frames_t_.back())
    throw std::logic_error("Simulator::capture: a frame was already captured at t = " + std::to_string(t));
  SimFrame f;
  f.index = frames_true_.size();
  f.t_s = t;
  f.body_true = truth_;
  f.body_estimate = bodyEstimate();
  f.body_odometry = odometry_.pose();
  f.T_W_S_true = sensorPose(truth_);
  f.T_W_S_estimate = sensorPose(f.body_estimate);
  f.depth = camera_.render(world_, f.T_W_S_true, f.index);

  // The pose graph: a node per frame at its estimate, an odometry edge from the previous frame
  // whose noise is the drift accumulated over one frame interval (variance sigma^2 dt_frame dt_step).
  const FlatPose odom = odometry_.pose();
  graph_.addNode(f.body_estimate);
  if (!frames_odom_.empty()) {
    const double interval = t - frames_t_.back();
    const double dt_step = 1.0 / config_.drift.rate_hz;
    PoseGraphEdge e;
    e.from = f.index - 1;
    e.to = f.index;
    e.relative = relativePose(frames_odom_.back(), odom);
    e.sigma_m = std::max(std::sqrt(config_.drift.sigma2_xyz_m2ps2 * interval * dt_step), config_.odometry_sigma_floor);
    e.sigma_yaw_rad = std::max(std::sqrt(config_.drift.sigma2_yaw_rad2ps2 * interval * dt_step) +
                                   std::abs(config_.drift.mu_yaw_radps) * interval,
                               config_.odometry_sigma_floor);
    graph_.addEdge(e);
  }
  frames_t_.push_back(t);
  frames_true_.push_back(truth_);
  frames_odom_.push_back(odom);
  frames_T_W_S_true_.push_back(f.T_W_S_true);

  if (config_.loop_closure == LoopClosureMode::Off) return f;
  const auto overlap = [&](std::size_t old_frame) {
    return viewOverlap(world_, camera_.intrinsics(), camera_.config().max_range_m, f.depth, f.T_W_S_true,
                       frames_T_W_S_true_[old_frame], config_.loop.overlap_pixel_stride);
  };
  if (const auto loop = detector_.addFrame(f.index, t, truth_, overlap)) f.correction = correct(*loop, t);
  return f;
}

CorrectionEvent Simulator::correct(const LoopClosure& loop, double t_s) {
  CorrectionEvent event;
  event.frame = loop.new_frame;
  event.t_s = t_s;
  event.loop = loop;
  if (config_.loop_closure == LoopClosureMode::Perfect) {
    for (std::size_t i = 0; i < frames_true_.size(); ++i) graph_.setPose(i, frames_true_[i]);
  } else {
    // The loop edge: the true relative pose of the two frames plus measurement noise.
    std::normal_distribution<double> unit(0.0, 1.0);
    PoseGraphEdge e;
    e.from = loop.old_frame;
    e.to = loop.new_frame;
    e.relative = relativePose(frames_true_[loop.old_frame], frames_true_[loop.new_frame]);
    for (int a = 0; a < 3; ++a) e.relative.position_W[a] += config_.loop_sigma_m * unit(loop_noise_rng_);
    e.relative.yaw_rad += config_.loop_sigma_yaw_rad * unit(loop_noise_rng_);
    e.sigma_m = std::max(config_.loop_sigma_m, config_.odometry_sigma_floor);
    e.sigma_yaw_rad = std::max(config_.loop_sigma_yaw_rad, config_.odometry_sigma_floor);
    graph_.addEdge(e);
    event.solve = graph_.optimize(config_.solve);
  }
  for (std::size_t i = 0; i < graph_.size(); ++i) event.T_W_S_by_frame[i] = sensorPose(graph_.pose(i));
  // Later estimates continue from the corrected pose of the newest frame.
  anchor_ = anchorOnto(graph_.pose(loop.new_frame), frames_odom_[loop.new_frame]);
  loops_.push_back(loop);
  return event;
}

}  // namespace vdbmap::sim
