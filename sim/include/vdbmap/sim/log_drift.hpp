// Perturbing a recorded log's poses with seeded odometry drift, to test loop-closure correction
// on real data.
//
// The generator: a random walk per frame in translation (each axis ~ N(0, sigma_t^2)) and in yaw
// (~ N(0, sigma_yaw^2)) about the gravity axis through the first camera position. Gravity is taken
// as the mean "down" axis (image y) of the cameras, so it works for datasets whose world z is not
// vertical (7-Scenes). Frame k's odometry pose is D_k * T_true_k with D_k the accumulated drift.
// One correction event is written at the frame where the true camera returns nearest to its start
// (searched after `min_loop_fraction` of the sequence): it lists the true poses of every frame up
// to the event. After the event the odometry is re-anchored (as a SLAM front end does after a loop
// closure) and drifts on from zero. groundtruth.txt holds the true poses.
#pragma once

#include "vdbmap/io/frame_source.hpp"

#include <cstdint>
#include <filesystem>

namespace vdbmap::sim {

struct LogDriftConfig {
  double sigma_translation_m = 0.003;  ///< per frame, per axis; [0, 1]
  double sigma_yaw_deg = 0.15;         ///< per frame; [0, 10]
  double min_loop_fraction = 0.5;      ///< the loop event is searched after this fraction; [0, 1)
  std::uint32_t seed = 1;
  void validate() const;
};

struct DriftedLog {
  std::size_t frames = 0;
  std::size_t event_frame = 0;       ///< where the correction event applies
  double loop_distance_m = 0.0;      ///< true distance between the event frame and frame 0
  double drift_at_event_m = 0.0;     ///< odometry position error at the event
  double drift_at_event_deg = 0.0;   ///< odometry yaw error at the event
};

/// Writes a log folder `out` (sensor.json, frames.csv referring to the source's depth files by
/// absolute path, corrections/<t>.txt, groundtruth.txt) from a depth dataset with true poses.
/// Throws std::invalid_argument for a point-cloud source or one with fewer than 3 frames.
DriftedLog writeDriftedLog(const io::FrameSource& source, const std::filesystem::path& out, const LogDriftConfig& config);

}  // namespace vdbmap::sim
