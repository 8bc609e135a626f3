// How the map encodes a voxel, and the one decoder of that encoding.
//
// Per voxel the map holds two 64-bit integers in fixed point: the weight sum W (one ray of weight
// 1 adds the map's weight scale) and the weighted signed-distance sum WD (a voxel at signed
// distance +truncation adds kSdfScale per weight unit). Integer sums are exact and
// order-independent, which is what makes de-integration exact. Everything that turns sums into a
// tsdf, a weight or a state goes through VoxelCodec, so the map, its readers (the planner's map
// query) and its exports can never disagree on a voxel.
#pragma once

#include "vdbmap/config.hpp"

#include <cstdint>
#include <limits>

namespace vdbmap {

/// Fixed-point scales of the exact state (see above). Internal to the map: readers decode through
/// VoxelCodec and never name these.
inline constexpr std::int64_t kSdfScale = 32768;
/// The smallest weight scale, and the one of every map whose max range is at most 5.06 m (the
/// default 5 m included) and of every map saved before the scale followed the range.
inline constexpr std::int64_t kMinWeightScale = 1024;
/// The largest: with kSdfScale it leaves 2^21 updates of a voxel at 0.1 m range before WD could
/// overflow 64 bits.
inline constexpr std::int64_t kMaxWeightScale = std::int64_t(1) << 20;
/// A ray at max range weighs at least this many units with the scale weightScaleFor chooses, so
/// rounding its 1/z^2 weight errs by at most 1/80 (1.25 %). 40 keeps the default 5 m at 1024.
inline constexpr std::int64_t kMinUnitsAtMaxRange = 40;

/// The weight scale a map of these settings uses: tsdf.weight_scale when set, else with
/// inverse-square weighting the smallest kMinWeightScale * 4^k whose ray at max range weighs at
/// least kMinUnitsAtMaxRange units (1024 up to 5.06 m, 4096 up to 10.1 m, ..., capped at
/// kMaxWeightScale from 161.9 m, where a ray at 1000 m still weighs 1 unit); with constant weighting
/// kMinWeightScale.
std::int64_t weightScaleFor(const TsdfConfig& tsdf, const IntegratorConfig& integrator);

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
  /// `config` is a map's (TsdfVolume::config()), whose weight_scale is set; throws
  /// std::invalid_argument when it is 0.
  explicit VoxelCodec(const TsdfConfig& config)
      : weight_scale_(checkedScale(config.weight_scale)),
        min_weight_q_(config.min_weight * weight_scale_),
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
  float weight(std::int64_t w) const { return float(double(w) / weight_scale_); }
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
  static double checkedScale(std::int64_t weight_scale);

  double weight_scale_;
  double min_weight_q_;
  double truncation_m_;
  double occupied_below_m_;
};

}  // namespace vdbmap
