// Collision events (sim/collision_events.hpp): one event per contact, not per crossing of the radius.
#include <catch2/catch.hpp>

#include "vdbmap/sim/collision_events.hpp"

#include <limits>
#include <stdexcept>
#include <vector>

using vdbmap::sim::CollisionEvents;

namespace {
constexpr double kRadius_m = 0.2;

std::size_t eventsOf(const std::vector<double>& clearances_m, double hysteresis_m) {
  CollisionEvents events(kRadius_m, hysteresis_m);
  for (const double c : clearances_m) events.add(c);
  return events.count();
}
}  // namespace

TEST_CASE("Hovering at the radius counts one collision event; leaving past the hysteresis ends it",
          "[sim][collision]") {
  // Hover around 0.2 m (crossing it four times), back off to 0.25 m, then a second contact.
  const std::vector<double> path{0.50, 0.199, 0.201, 0.198, 0.2005, 0.199, 0.25, 0.30, 0.15, 0.35};
  CHECK(eventsOf(path, 0.02) == 2);
  CHECK(eventsOf(path, 0.0) == 4);  // without hysteresis every re-entry counts
  CollisionEvents events(kRadius_m);
  for (const double c : path) events.add(c);
  CHECK(events.minClearance() == 0.15);
  CHECK_FALSE(events.colliding());
}

TEST_CASE("A path that keeps its radius has no collision event", "[sim][collision]") {
  CollisionEvents events(kRadius_m);
  CHECK(events.minClearance() == std::numeric_limits<double>::infinity());
  for (const double c : {1.0, 0.5, 0.2, 0.21, 0.2}) events.add(c);  // touching 0.2 m is not closer than it
  CHECK(events.count() == 0);
  CHECK(events.minClearance() == 0.2);
  CHECK_THROWS_AS(CollisionEvents(-0.1), std::invalid_argument);
  CHECK_THROWS_AS(CollisionEvents(0.2, std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
}
