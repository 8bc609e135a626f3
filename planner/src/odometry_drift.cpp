#include "vdbmap/planner/odometry_drift.hpp"
#include "vdbmap/field_check.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace vdbmap::planner {

void OdometryDrift::validate() const {
  const FieldCheck check("OdometryDrift");
  check.inRange("position_m_per_sqrt_s", position_m_per_sqrt_s, 0.0, 10.0);
  check.inRange("position_bias_m_per_s", position_bias_m_per_s, -10.0, 10.0);
  check.inRange("yaw_rad_per_sqrt_s", yaw_rad_per_sqrt_s, 0.0, 10.0);
  check.inRange("yaw_bias_rad_per_s", yaw_bias_rad_per_s, -1.0, 1.0);
}

double OdometryDrift::displacement_m(double t_s, double lever_m) const {
  if (!(t_s >= 0.0 && std::isfinite(t_s) && lever_m >= 0.0 && std::isfinite(lever_m)))
    throw std::invalid_argument("OdometryDrift::displacement_m: t_s and lever_m must be finite and >= 0");
  const double root_t = std::sqrt(t_s);
  return std::sqrt(3.0) * (position_m_per_sqrt_s * root_t + std::abs(position_bias_m_per_s) * t_s) +
         lever_m * (yaw_rad_per_sqrt_s * root_t + std::abs(yaw_bias_rad_per_s) * t_s);
}

double OdometryDrift::displacement_m(double t_s, double lever_m, double path_m) const {
  const double without_path = displacement_m(t_s, lever_m);
  if (!(path_m >= 0.0 && std::isfinite(path_m)))
    throw std::invalid_argument("OdometryDrift::displacement_m: path_m must be finite and >= 0");
  return without_path + path_m * (yaw_rad_per_sqrt_s * std::sqrt(t_s / 3.0) + std::abs(yaw_bias_rad_per_s) * t_s / 2.0);
}

double OdometryDrift::axisDisplacement_m(double t_s) const {
  if (!(t_s >= 0.0 && std::isfinite(t_s)))
    throw std::invalid_argument("OdometryDrift::axisDisplacement_m: t_s must be finite and >= 0");
  return position_m_per_sqrt_s * std::sqrt(t_s) + std::abs(position_bias_m_per_s) * t_s;
}

double OdometryDrift::longestWithin(double tolerance_m, double lever_m, double min_s, double max_s) const {
  if (!(tolerance_m >= 0.0 && std::isfinite(tolerance_m) && min_s >= 0.0 && min_s <= max_s && std::isfinite(max_s)))
    throw std::invalid_argument(
        "OdometryDrift::longestWithin: needs a finite tolerance_m >= 0 and finite 0 <= min_s <= max_s");
  if (displacement_m(max_s, lever_m) <= tolerance_m) return max_s;
  if (tolerance_m == 0.0 || displacement_m(min_s, lever_m) > tolerance_m) return min_s;
  // The displacement is b sqrt(t) + c t with b, c >= 0, not both 0 (else max_s was returned):
  // the root x = sqrt(t) of c x^2 + b x = tolerance_m, in the form without cancellation.
  const double b = std::sqrt(3.0) * position_m_per_sqrt_s + lever_m * yaw_rad_per_sqrt_s;
  const double c = std::sqrt(3.0) * std::abs(position_bias_m_per_s) + lever_m * std::abs(yaw_bias_rad_per_s);
  const double x = 2.0 * tolerance_m / (b + std::sqrt(b * b + 4.0 * c * tolerance_m));
  return std::clamp(x * x, min_s, max_s);
}

}  // namespace vdbmap::planner
