#include "vdbmap/sim/collision_events.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace vdbmap::sim {

CollisionEvents::CollisionEvents(double radius_m, double hysteresis_m)
    : radius_m_(radius_m), hysteresis_m_(hysteresis_m) {
  if (!(std::isfinite(radius_m) && radius_m >= 0.0))
    throw std::invalid_argument("CollisionEvents: radius_m must be finite and >= 0");
  if (!(std::isfinite(hysteresis_m) && hysteresis_m >= 0.0))
    throw std::invalid_argument("CollisionEvents: hysteresis_m must be finite and >= 0");
}

void CollisionEvents::add(double clearance_m) {
  min_clearance_m_ = std::min(min_clearance_m_, clearance_m);
  if (!colliding_ && clearance_m < radius_m_) {
    colliding_ = true;
    ++count_;
  } else if (colliding_ && clearance_m > radius_m_ + hysteresis_m_) {
    colliding_ = false;
  }
}

}  // namespace vdbmap::sim
