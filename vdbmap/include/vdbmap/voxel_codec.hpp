// How the map encodes a voxel, and the one decoder of that encoding.
//
// Per voxel the map holds two 64-bit integers in fixed point: the weight sum W (one ray of weight
// 1 adds kWeightScale) and the weighted signed-distance sum WD (a voxel at signed distance
// +truncation adds kSdfScale per weight unit). Integer sums are exact and order-independent,
// which is what makes de-integration exact. Everything that turns sums into a tsdf, a weight or a
// state goes through VoxelCodec, so the map, its readers (the planner's map query) and its
// exports can never disagree on a voxel.
#pragma once

#include "vdbmap/config.hpp"

#include <cstdint>
#include <limits>

namespace vdbmap {

/// Fixed-point scales of the exact state (see above). Internal to the map: readers decode through
/// VoxelCodec and never name these.
inline constexpr std::int64_t kWeightScale = 1024;
inline constexpr std::int64_t kSdfScale = 32768;

enum class VoxelState : std::uint8_t { Unknown, Free, Occupied };
const char* toString(VoxelState s);

/// One voxel's value, read from the exact state.
struct VoxelSample {
  VoxelState state = VoxelState::Unknown;
  float tsdf_m = 0.0f;   ///< weighted mean signed distance; +truncation when unknown
  float weight = 0.0f;   ///< weight sum in ray units (0 when never observed)
  /// Surface end points of the integrated frames that fell in this voxel. A voxel can read free
  /// (rays passing beside a thin upright carve it) and still hold hits: the planner reads those
  /// as obstacles. Negative only in a map loaded from a format-2 companion, which had no counts.
  std::int64_t hits = 0;
};

/// Decodes a voxel's exact sums (W, WD) under one map's configuration: known when W exceeds
/// min_weight (paper Sect. IV-A), occupied when known and tsdf < occupancy_threshold_vox voxels.
class VoxelCodec {
 public:
  explicit VoxelCodec(const TsdfConfig& config)
      : min_weight_q_(config.min_weight * double(kWeightScale)),
        truncation_m_(config.truncation_m()),
        occupied_below_m_(config.occupancy_threshold_vox * config.voxel_size_m) {}

  bool known(std::int64_t w) const { return w > 0 && double(w) > min_weight_q_; }
  /// The tsdf in metres of a known voxel (W > 0).
  float knownTsdf(std::int64_t w, std::int64_t wd) const {
    return float(double(wd) / double(w) / double(kSdfScale) * truncation_m_);
  }
  /// The tsdf in metres, NaN when the voxel is unknown.
  float tsdfOrNan(std::int64_t w, std::int64_t wd) const {
    return known(w) ? knownTsdf(w, wd) : std::numeric_limits<float>::quiet_NaN();
  }
  /// The weight sum in ray units.
  static float weight(std::int64_t w) { return float(double(w) / double(kWeightScale)); }
  /// Whether a known voxel with this tsdf reads occupied.
  bool occupied(float tsdf_m) const { return tsdf_m < occupied_below_m_; }
  /// State, tsdf (+truncation when unknown) and weight; `hits` is left 0.
  VoxelSample decode(std::int64_t w, std::int64_t wd) const {
    VoxelSample s;
    s.weight = weight(w);
    if (!known(w)) {
      s.tsdf_m = float(truncation_m_);
      s.state = VoxelState::Unknown;
      return s;
    }
    s.tsdf_m = knownTsdf(w, wd);
    s.state = occupied(s.tsdf_m) ? VoxelState::Occupied : VoxelState::Free;
    return s;
  }

 private:
  double min_weight_q_;
  double truncation_m_;
  double occupied_below_m_;
};

}  // namespace vdbmap
