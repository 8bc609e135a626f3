#include "vdbmap/config.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace vdbmap {
namespace {
template <typename T>
void requireRange(const char* owner, const char* field, T value, T lo, T hi, const char* range_text) {
  if (!(value >= lo && value <= hi)) {  // also rejects NaN
    std::ostringstream msg;
    msg << owner << "." << field << " must be in " << range_text << ", got " << value;
    throw std::invalid_argument(msg.str());
  }
}
}  // namespace

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
  if (!(voxel_size_m >= 1e-4 && voxel_size_m <= 10.0)) {  // below 0.1 mm OpenVDB's transforms lose precision
    std::ostringstream msg;
    msg << "TsdfConfig.voxel_size_m must be in [1e-4, 10], got " << voxel_size_m;
    throw std::invalid_argument(msg.str());
  }
  requireRange("TsdfConfig", "truncation_vox", truncation_vox, 1.0, 100.0, "[1, 100]");
  if (!(min_weight >= 0.0 && min_weight < 1e6)) {
    std::ostringstream msg;
    msg << "TsdfConfig.min_weight must be in [0, 1e6), got " << min_weight;
    throw std::invalid_argument(msg.str());
  }
  requireRange("TsdfConfig", "occupancy_threshold_vox", occupancy_threshold_vox, -truncation_vox, truncation_vox,
               "[-truncation_vox, truncation_vox]");
}

void IntegratorConfig::validate() const {
  if (!(max_range_m > 0.0 && max_range_m <= 1000.0)) {
    std::ostringstream msg;
    msg << "IntegratorConfig.max_range_m must be in (0, 1000], got " << max_range_m;
    throw std::invalid_argument(msg.str());
  }
  if (!(min_range_m >= 0.0 && min_range_m < max_range_m)) {
    std::ostringstream msg;
    msg << "IntegratorConfig.min_range_m must be in [0, max_range_m), got " << min_range_m;
    throw std::invalid_argument(msg.str());
  }
  requireRange("IntegratorConfig", "threads", threads, 0, 1024, "[0, 1024]");
}

}  // namespace vdbmap
