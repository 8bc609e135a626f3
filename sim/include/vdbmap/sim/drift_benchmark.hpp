// The paper's Table II in one call: map accuracy under odometry drift, per consistency mode.
//
// For each drift level (Table I, drift.hpp) the same flight (a waypoint file or the world's
// coverage pattern, coverage.hpp) is simulated once with loop closure (flight.hpp) and written as
// a log; every mode (none ~ Voxblox, submap ~ C-blox, all = ours without pruning, keyframes = ours)
// then replays that log through the Mapper (vdbmap/log_replay.hpp), and the mesh of its map is
// evaluated against the world's mesh (vdbmap/eval.hpp): RMSE of the map surface's distance to the
// ground truth, and completeness (ground truth within 2 voxels of the map).
//
// Output folder: <level>/log (the flight), <level>/<mode>.ply (meshes), table.json (one object
// per level and mode) and table.md (laid out like Table II, with the flights' statistics).
// The modes of a level replay concurrently, and with the next level's flight.
#pragma once

#include "vdbmap/mapper.hpp"
#include "vdbmap/sim/coverage.hpp"
#include "vdbmap/sim/flight.hpp"
#include "vdbmap/sim/simulator.hpp"
#include "vdbmap/sim/world.hpp"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace vdbmap::sim {

struct DriftBenchmarkConfig {
  std::filesystem::path world_mesh;  ///< PLY, OBJ or OFF
  WorldConfig world;
  std::vector<std::string> levels = {"s1", "s2", "s3", "s4"};
  std::vector<ConsistencyMode> modes = {ConsistencyMode::None, ConsistencyMode::Submap, ConsistencyMode::All,
                                        ConsistencyMode::Keyframes};
  std::uint64_t seed = 1;     ///< drift (and loop-edge noise) seed, the same for every level
  double voxel_size_m = 0.1;  ///< (0, 10]
  /// Flight: waypoints from this file when set, else the world's coverage pattern.
  std::filesystem::path trajectory_file;
  CoverageConfig coverage;
  MotionLimits limits;  ///< for a waypoint file
  /// Correction on loop closure. `perfect` (ground truth for every frame so far) by default: it
  /// is what the authors' simulator publishes (their mock loop replaces the path by ground truth),
  /// so Table II measures the mapping, not the pose-graph back end. `pgo` gives the 4-DOF
  /// optimization's corrections instead.
  LoopClosureMode loop_closure = LoopClosureMode::Perfect;
  /// Camera and loop-detection settings; drift and loop_closure are set from the fields above.
  SimulatorConfig simulator;
  /// Mapper settings besides mode and voxel size (integrator ranges come from the camera).
  MapperConfig mapper;
  double completeness_threshold_vox = 2.0;  ///< (0, 100]
  bool write_meshes = true;
  /// Called with a line of progress text.
  std::function<void(const std::string&)> report;

  void validate() const;
};

struct DriftBenchmarkRow {
  std::string level;
  std::string mode;
  double accuracy_rmse_m = 0.0;
  double accuracy_mean_m = 0.0;
  double completeness = 0.0;
  std::size_t frames_total = 0;
  std::size_t keyframes_kept = 0;
  std::size_t reintegrated_frames = 0;
  std::size_t correction_events = 0;
  /// Replay (integration, corrections, re-integration) of this mode; the modes of a level run
  /// concurrently, so their times overlap.
  double wall_s = 0.0;
};

struct DriftBenchmarkLevel {
  std::string level;
  FlightResult flight;
};

struct DriftBenchmarkResult {
  std::vector<DriftBenchmarkRow> rows;
  std::vector<DriftBenchmarkLevel> levels;
  double wall_s = 0.0;
};

/// Runs the benchmark into `out_dir` (created; existing logs there are overwritten). Throws
/// std::invalid_argument for an invalid config, std::runtime_error on I/O errors.
DriftBenchmarkResult runDriftBenchmark(const DriftBenchmarkConfig& config, const std::filesystem::path& out_dir);

/// table.md's text: Table II's layout (modes as rows, levels as columns) for RMSE, completeness
/// and kept frames, then the flights.
std::string driftBenchmarkMarkdown(const DriftBenchmarkResult& result, const DriftBenchmarkConfig& config);

}  // namespace vdbmap::sim
