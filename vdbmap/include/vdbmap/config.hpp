// Parameters of the TSDF map and of frame integration, with their defaults.
//
// Defaults live here only. Every struct has validate(), which throws std::invalid_argument naming
// the field and its allowed range.
#pragma once

#include <cstdint>
#include <string>

namespace vdbmap {

/// How much one ray counts in a voxel's weighted average.
enum class Weighting {
  Constant,       ///< every ray weighs 1
  InverseSquare,  ///< 1/z^2 (z = depth along the optical axis), with the paper's Eq. 2 linear
                  ///< drop-off behind the surface: from -voxel_size down to -truncation it falls
                  ///< linearly to 0
};

/// How a frame becomes voxel updates.
///  - Projective (the default): depth images are integrated voxel by voxel, each voxel of the
///    camera frustum projected into the image and updated once per frame by its pixel (as
///    KinectFusion, Open3D and nvblox do); point clouds, which have no image, use Merged rays.
///  - Merged: rays that end in the same voxel are bundled into one (voxblox's "merged"
///    integrator); every voxel a bundle crosses is updated once per bundle.
///  - PerRay: every point casts its own ray (slow, the reference).
/// All three give the sdf of DESIGN section 4 along the rays; they differ in how often a voxel
/// crossed by several rays is counted (its weight), and in speed.
enum class RayMode { Merged, PerRay, Projective };

const char* toString(Weighting w);
const char* toString(RayMode m);
/// Parses "constant" / "inverse_square"; throws std::invalid_argument listing the choices.
Weighting parseWeighting(const std::string& text);
/// Parses "projective" / "merged" / "per_ray"; throws std::invalid_argument listing the choices.
RayMode parseRayMode(const std::string& text);

/// The map's geometry and the meaning of its values.
struct TsdfConfig {
  double voxel_size_m = 0.1;               ///< edge of a voxel; (0, 10]
  double truncation_vox = 3.0;             ///< truncation distance delta in voxels; [1, 100]
  Weighting weighting = Weighting::InverseSquare;
  /// tau_w of the paper (Sect. IV-A): a voxel is *known* when its weight sum exceeds this. One ray
  /// weighs 1 (constant) or 1/z^2 (inverse_square), so the default 1e-3 means "seen at all".
  double min_weight = 1e-3;                ///< [0, 1e6)
  /// A known voxel is *occupied* when its tsdf is below this many voxels, else *free*. 0.5 makes
  /// the voxel that contains the surface occupied.
  double occupancy_threshold_vox = 0.5;    ///< [-truncation_vox, truncation_vox]
  /// Fixed-point units of one ray of weight 1 in the map's exact sums (docs/conventions.md). 0, the
  /// default, lets the map choose it from the integrator's max range (weightScaleFor in
  /// voxel_codec.hpp); a map keeps the scale it was made with, also when saved and loaded.
  std::int64_t weight_scale = 0;  ///< 0 or a power of two in [1024, 2^20]

  double truncation_m() const { return truncation_vox * voxel_size_m; }
  void validate() const;
};

/// How frames are turned into ray updates. Part of a map's identity: a frame is de-integrated
/// with the same settings it was integrated with.
struct IntegratorConfig {
  double min_range_m = 0.1;  ///< points closer than this are invalid (skipped, counted); [0, max_range_m)
  /// Points beyond this carve free space up to it and add no surface; (min_range_m, 1000]
  double max_range_m = 5.0;
  RayMode ray_mode = RayMode::Projective;
  /// Worker threads for integration; 0 = TBB's default (all cores). The map does not depend on it.
  int threads = 0;            ///< [0, 1024]

  void validate() const;
};

}  // namespace vdbmap
