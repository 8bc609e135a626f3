#include "vdbmap/config.hpp"

#include "vdbmap/field_check.hpp"
#include "vdbmap/voxel_codec.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace vdbmap {

const char* toString(Weighting w) { return w == Weighting::Constant ? "constant" : "inverse_square"; }
const char* toString(RayMode m) {
  switch (m) {
    case RayMode::Merged: return "merged";
    case RayMode::PerRay: return "per_ray";
    case RayMode::Projective: return "projective";
  }
  return "?";
}

Weighting parseWeighting(const std::string& text) {
  if (text == "constant") return Weighting::Constant;
  if (text == "inverse_square") return Weighting::InverseSquare;
  throw std::invalid_argument("weighting must be constant or inverse_square, got '" + text + "'");
}

RayMode parseRayMode(const std::string& text) {
  if (text == "merged") return RayMode::Merged;
  if (text == "per_ray") return RayMode::PerRay;
  if (text == "projective") return RayMode::Projective;
  throw std::invalid_argument("ray mode must be projective, merged or per_ray, got '" + text + "'");
}

void TsdfConfig::validate() const {
  const FieldCheck check("TsdfConfig");
  // Below 0.1 mm OpenVDB's transforms lose precision.
  if (!(voxel_size_m >= 1e-4 && voxel_size_m <= 10.0)) check.fail("voxel_size_m", "[1e-4, 10]", voxel_size_m);
  check.inRange("truncation_vox", truncation_vox, 1.0, 100.0);
  if (!(min_weight >= 0.0 && min_weight < 1e6)) check.fail("min_weight", "[0, 1e6)", min_weight);
  if (!(occupancy_threshold_vox >= -truncation_vox && occupancy_threshold_vox <= truncation_vox))
    check.fail("occupancy_threshold_vox", "[-truncation_vox, truncation_vox]", occupancy_threshold_vox);
  const bool power_of_two = weight_scale > 0 && (weight_scale & (weight_scale - 1)) == 0;
  if (weight_scale != 0 && !(power_of_two && weight_scale >= kMinWeightScale && weight_scale <= kMaxWeightScale))
    check.fail("weight_scale", "{0} or the powers of two in [1024, 1048576]", double(weight_scale));
}

void IntegratorConfig::validate() const {
  const FieldCheck check("IntegratorConfig");
  if (!(max_range_m > 0.0 && max_range_m <= 1000.0)) check.fail("max_range_m", "(0, 1000]", max_range_m);
  if (!(min_range_m >= 0.0 && min_range_m < max_range_m)) check.fail("min_range_m", "[0, max_range_m)", min_range_m);
  check.inRange("threads", threads, 0, 1024);
}

}  // namespace vdbmap
