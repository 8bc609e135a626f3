// An offline flight: fly a given trajectory through the online Simulator and record it as a log
// (vdbmap/io/log_writer.hpp): depth/<n>.png, frames.csv with the pose estimates of each capture,
// corrections/<t>.txt per loop closure, groundtruth.txt, plus simulation.json (settings, loop
// closures, drift statistics). Every mapping mode then replays exactly the same flight.
//
// The vehicle advances at the drift rate (200 Hz) along the trajectory and captures a frame at
// every camera period from the trajectory's start to its end (flyAlong).
#pragma once

#include "vdbmap/sim/simulator.hpp"
#include "vdbmap/sim/trajectory.hpp"
#include "vdbmap/timing.hpp"

#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace vdbmap::sim {

struct FlightConfig {
  bool overwrite = false;  ///< allow writing into a folder that already holds a log
  /// Free text stored in simulation.json (e.g. the command line, the drift level's name).
  std::string description;
  /// Called after every frame with (frames done, frames to do).
  std::function<void(std::size_t, std::size_t)> progress;
};
using FlightOptions [[deprecated("renamed FlightConfig")]] = FlightConfig;

struct FlightResult {
  std::size_t frames = 0;
  double duration_s = 0.0;
  double path_length_m = 0.0;
  std::vector<LoopClosure> loop_closures;
  /// Position error of the raw odometry (no loop closure) at the last frame, and its maximum.
  double odometry_error_final_m = 0.0;
  double odometry_error_max_m = 0.0;
  /// Position error of the published estimates (what frames.csv holds): RMSE and maximum.
  double estimate_error_rmse_m = 0.0;
  double estimate_error_max_m = 0.0;
  /// Per frame: drift steps, rendering, loop detection, pose graph and writing the frame.
  double frame_ms_median = 0.0;
  double wall_s = 0.0;
};

/// Moves the simulator along `trajectory` (the true poses) from its current time to t_end_s:
/// advances at the drift rate and captures every frame that falls due (Simulator::nextFrameTime),
/// handing each to `on_frame`. The building block of simulateFlight and of closed-loop flights (a
/// planner calls it with its newest trajectory, then replans). Throws std::invalid_argument for an
/// empty trajectory.
void flyAlong(Simulator& sim, const SampledTrajectory& trajectory, double t_end_s,
              const std::function<void(SimFrame&)>& on_frame);

/// The same with the true pose given per step by `truth_at(t)`, called once per drift step (and
/// at each frame time) in increasing t, after the simulator has advanced to the step before: a
/// closed loop computes the true pose there from the estimate the simulator holds.
void flyAlong(Simulator& sim, const std::function<FlatPose(double)>& truth_at, double t_end_s,
              const std::function<void(SimFrame&)>& on_frame);

/// Records a flight frame by frame as a log (see the file comment) and gathers its statistics:
/// the recording part of simulateFlight, shared with closed-loop flights.
class FlightRecorder {
 public:
  /// Opens the log (io::LogWriter). Throws std::runtime_error when `log_dir` holds a log and
  /// overwrite is false, or a file cannot be written.
  FlightRecorder(const std::filesystem::path& log_dir, const Simulator& sim, bool overwrite);
  ~FlightRecorder();
  FlightRecorder(const FlightRecorder&) = delete;
  FlightRecorder& operator=(const FlightRecorder&) = delete;

  /// Writes the frame (depth with its pose estimate, ground truth, the correction if any) and
  /// updates the error statistics.
  void record(const SimFrame& frame);
  std::size_t frames() const { return frame_t_.size(); }

  /// Closes the log and writes simulation.json (settings, description, loop closures, drift
  /// statistics). Returns the statistics; the caller gives the flight's duration and path length.
  FlightResult finish(const SimulatorConfig& config, const std::string& description, double duration_s,
                      double path_length_m);

 private:
  struct Log;
  std::unique_ptr<Log> log_;
  FlightResult result_;
  std::vector<double> frame_t_, frame_ms_;
  double sq_error_ = 0.0;
  Stopwatch since_start_, since_last_frame_;
};

/// Flies `trajectory` and writes the log to `log_dir`. Throws std::invalid_argument for an empty
/// trajectory or an invalid config, std::runtime_error when `log_dir` holds a log and overwrite
/// is false or a file cannot be written.
FlightResult simulateFlight(const World& world, const SampledTrajectory& trajectory, const SimulatorConfig& config,
                            const std::filesystem::path& log_dir, const FlightConfig& options = {});

}  // namespace vdbmap::sim
