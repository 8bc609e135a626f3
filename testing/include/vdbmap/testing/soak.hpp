// The integrate/de-integrate soak: many cycles of random frames at random poses through one map,
// which must return to empty exactly, with memory that stays flat. The benchmark (10,000 cycles,
// bench/bench_soak.cpp) and a short test share it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace vdbmap::testing {

struct SoakParams {
  int cycles = 10000;          ///< frames integrated (each later de-integrated)
  int live_frames = 8;         ///< frames held at once; beyond it a random live frame is removed
  int width = 64, height = 48; ///< depth images (points frames hold width x height / 4 points)
  double voxel_size_m = 0.05;
  double pose_box_m = 4.0;     ///< poses uniform in a cube of this half-width around the origin
  std::uint64_t seed = 1;
  int memory_samples = 10;     ///< resident-memory readings spread over the run
  int threads = 0;             ///< integrator threads (0 = all cores)

  /// Throws std::invalid_argument naming the field out of range.
  void validate() const;
};

struct SoakResult {
  int integrations = 0, deintegrations = 0;
  int depth_frames = 0, point_frames = 0;
  std::size_t max_active_voxels = 0;  ///< the largest map during the run
  /// After the last de-integration: active voxels of the weight, weighted-sdf and hit grids
  /// (all 0 when the map is empty exactly) and frames still registered.
  std::size_t weight_voxels_after = 0, wsdf_voxels_after = 0, hit_voxels_after = 0, frames_after = 0;
  std::size_t memory_bytes_after = 0;  ///< the map's own memory when empty (OpenVDB's memUsage)
  /// (cycle, resident set size in KiB) at memory_samples points, the first after the map is
  /// warm (cycle = live_frames), the last at the end.
  std::vector<std::pair<int, std::size_t>> rss_kib;
  double seconds = 0.0;

  bool emptyExactly() const {
    return weight_voxels_after == 0 && wsdf_voxels_after == 0 && hit_voxels_after == 0 && frames_after == 0;
  }
};

/// Runs the soak: frames alternate between depth images (projective integration) and point
/// clouds (ray integration); depths are uniform in [0.2, 6] m with 10 % invalid pixels, poses
/// uniform in the cube with uniformly random orientation, all drawn from `seed`.
SoakResult runIntegrateDeintegrateSoak(const SoakParams& params);

}  // namespace vdbmap::testing
