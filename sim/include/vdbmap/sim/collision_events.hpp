// Distinct collision events along a sampled path of clearances.
//
// An event starts when the clearance drops below the vehicle's radius and ends only when it is
// back above radius + hysteresis_m. Without the hysteresis, a vehicle hovering at its radius from
// a wall (0.198, 0.201, 0.199 m, ...) would count one event per sample that crosses it.
#pragma once

#include <cstddef>
#include <limits>

namespace vdbmap::sim {

class CollisionEvents {
 public:
  /// Throws std::invalid_argument unless radius_m and hysteresis_m are finite and >= 0.
  explicit CollisionEvents(double radius_m, double hysteresis_m = 0.02);

  /// The clearance at the next sample of the path (distance to the nearest surface, metres).
  void add(double clearance_m);

  std::size_t count() const { return count_; }
  double minClearance() const { return min_clearance_m_; }  ///< infinity before the first sample
  bool colliding() const { return colliding_; }

 private:
  double radius_m_;
  double hysteresis_m_;
  bool colliding_ = false;
  std::size_t count_ = 0;
  double min_clearance_m_ = std::numeric_limits<double>::infinity();
};

}  // namespace vdbmap::sim
