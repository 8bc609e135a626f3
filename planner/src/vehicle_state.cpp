#include "vdbmap/planner/vehicle_state.hpp"

#include <cmath>

namespace vdbmap::planner {

double wrapAngle(double a_rad) {
  const double a = std::remainder(a_rad, 2.0 * M_PI);  // in [-pi, pi]
  return a <= -M_PI ? a + 2.0 * M_PI : a;
}

double angleDifference(double to_rad, double from_rad) { return wrapAngle(to_rad - from_rad); }

double yawDistance(double a_rad, double b_rad) { return std::abs(wrapAngle(b_rad - a_rad)); }

}  // namespace vdbmap::planner
