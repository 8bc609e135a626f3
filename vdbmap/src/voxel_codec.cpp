#include "vdbmap/voxel_codec.hpp"

#include <stdexcept>

namespace vdbmap {

const char* toString(VoxelState s) {
  switch (s) {
    case VoxelState::Unknown: return "unknown";
    case VoxelState::Free: return "free";
    case VoxelState::Occupied: return "occupied";
  }
  return "?";
}

std::int64_t weightScaleFor(const TsdfConfig& tsdf, const IntegratorConfig& integrator) {
  if (tsdf.weight_scale != 0) return tsdf.weight_scale;
  if (tsdf.weighting == Weighting::Constant) return kMinWeightScale;
  // A ray's weight is scale / z^2 with z at most the max range (beyond it rays are cut there).
  const double needed = double(kMinUnitsAtMaxRange) * integrator.max_range_m * integrator.max_range_m;
  std::int64_t scale = kMinWeightScale;
  while (double(scale) < needed && scale < kMaxWeightScale) scale *= 4;
  return scale;
}

double VoxelCodec::checkedScale(std::int64_t weight_scale) {
  if (weight_scale <= 0)
    throw std::invalid_argument("VoxelCodec needs a map's TsdfConfig, whose weight_scale is set (got " +
                                std::to_string(weight_scale) + ")");
  return double(weight_scale);
}

}  // namespace vdbmap
