// The online simulator: one vehicle in a World, stepped by whoever moves it (an offline flight
// along a given trajectory, flight.hpp, or a planner in closed loop).
//
// Per step the caller gives the vehicle's TRUE flat pose at time t (advance); the simulator
// integrates odometry drift up to t (drift.hpp). Per camera frame (capture) it renders depth from
// the true pose, publishes the pose ESTIMATE of that moment (drifting odometry, re-anchored by the
// last loop closure, as VINS's loop fusion publishes it), adds the frame to a 4-DOF pose graph
// (odometry edges between consecutive frames), and checks for a loop closure against the true
// poses (loop_closure.hpp). When one is found, it returns a correction event listing the
// optimized sensor pose T_W_S of EVERY frame so far: by pose-graph optimization with the loop edge
// (`pgo`), or the ground truth (`perfect`, what the authors' mock loop publishes); `off` never
// closes loops. After an event, estimates of later frames continue from the corrected pose.
//
// Frames: the body B is x forward, y left, z up at the flat pose; the camera S looks along body
// x, pitched down by `camera_pitch_rad`, with OpenCV axes (T_B_S = lookingPose(0, 0, pitch)).
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/sim/depth_camera.hpp"
#include "vdbmap/sim/drift.hpp"
#include "vdbmap/sim/loop_closure.hpp"
#include "vdbmap/sim/pose_graph.hpp"
#include "vdbmap/sim/world.hpp"
#include "vdbmap/types.hpp"

#include <cstddef>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace vdbmap::sim {

enum class LoopClosureMode { Off, PoseGraph, Perfect };
/// "off", "pgo", "perfect".
const char* toString(LoopClosureMode mode);
/// Inverse of toString; throws std::invalid_argument listing the choices.
LoopClosureMode parseLoopClosureMode(const std::string& text);

struct SimulatorConfig {
  DepthCameraConfig camera;
  double camera_pitch_rad = 0.0;  ///< downward pitch of the camera on the body; [-pi/2, pi/2]
  DriftConfig drift;              ///< s1 (none) by default
  LoopClosureConfig loop;
  LoopClosureMode loop_closure = LoopClosureMode::PoseGraph;
  /// Measurement noise of a loop edge (added, seeded, to the true relative pose of the two
  /// frames), as a place-recognition front end's relative pose would carry: per axis and in yaw.
  double loop_sigma_m = 0.02;         ///< [0, 1]
  double loop_sigma_yaw_rad = 0.005;  ///< [0, 0.5]
  /// Floor of the odometry edges' standard deviations, which otherwise follow from the drift
  /// variances over one frame interval (zero at s1). [1e-9, 1]
  double odometry_sigma_floor = 1e-4;
  PoseGraphSolveConfig solve;

  void validate() const;
};

/// A loop-closure correction: the optimized T_W_S of every frame up to and including `frame`.
struct CorrectionEvent {
  std::size_t frame = 0;  ///< the frame that closed the loop; the event applies after it
  double t_s = 0.0;
  LoopClosure loop;
  std::map<std::size_t, Pose3d> T_W_S_by_frame;
  PoseGraphSummary solve;  ///< empty for `perfect`
};

/// One camera frame.
struct SimFrame {
  std::size_t index = 0;
  double t_s = 0.0;
  DepthImage depth;
  Pose3d T_W_S_true = Pose3d::Identity();
  Pose3d T_W_S_estimate = Pose3d::Identity();  ///< what the robot believes at capture time
  FlatPose body_true, body_estimate;
  FlatPose body_odometry;  ///< the raw drifting odometry, without loop-closure corrections
  std::optional<CorrectionEvent> correction;
};

class Simulator {
 public:
  /// The vehicle starts at `start` (true and estimated poses agree) at time t0_s. The world must
  /// outlive the simulator.
  Simulator(const World& world, const SimulatorConfig& config, const FlatPose& start, double t0_s = 0.0);

  /// Moves the vehicle to its true pose at t_s (not before the previous time). Call at the drift
  /// rate (200 Hz) for exact drift along curves; coarser calls interpolate linearly.
  void advance(double t_s, const FlatPose& truth);
  /// Renders and records a frame at the current time (at most one per time).
  SimFrame capture();

  double time() const { return odometry_.time(); }
  double startTime() const { return t0_; }
  /// When the next frame is due: frames are captured every camera period from the start time.
  double nextFrameTime() const { return t0_ + double(frames()) * camera_.period_s(); }
  const FlatPose& bodyTrue() const { return truth_; }
  /// The pose estimate now: the odometry re-anchored by the last correction.
  FlatPose bodyEstimate() const;
  const Pose3d& T_B_S() const { return T_B_S_; }
  /// Sensor pose of a body pose.
  Pose3d sensorPose(const FlatPose& body) const;

  std::size_t frames() const { return frames_true_.size(); }
  /// Every loop closure that produced a correction event, in order.
  const std::vector<LoopClosure>& loopClosures() const { return loops_; }
  const DepthCamera& camera() const { return camera_; }
  const World& world() const { return world_; }
  const SimulatorConfig& config() const { return config_; }

 private:
  CorrectionEvent correct(const LoopClosure& loop, double t_s);

  const World& world_;
  SimulatorConfig config_;
  DepthCamera camera_;
  Pose3d T_B_S_;
  DriftingOdometry odometry_;
  LoopDetector detector_;
  PoseGraph4Dof graph_;
  std::mt19937_64 loop_noise_rng_;
  double t0_ = 0.0;
  FlatPose truth_;
  FlatPose anchor_;                    ///< estimate = anchor_ composed with raw odometry
  std::vector<double> frames_t_;       ///< capture time per frame
  std::vector<FlatPose> frames_true_;  ///< true body pose per frame
  std::vector<FlatPose> frames_odom_;  ///< raw odometry body pose per frame
  std::vector<Pose3d> frames_T_W_S_true_;
  std::vector<LoopClosure> loops_;
};

}  // namespace vdbmap::sim
