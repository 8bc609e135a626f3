// A KD-tree over 3-D positions that grows one point at a time: nanoflann's dynamic index (a
// forest of static trees whose sizes are powers of two, merged by the logarithmic method, so an
// append costs amortised O(log^2 n) and a query O(log^2 n + hits)). The active-loop-closure
// history and its cluster centres use it for radius queries around the vehicle.
#pragma once

#include "vdbmap/types.hpp"

#include <cstddef>
#include <memory>
#include <vector>

namespace vdbmap::planner {

/// Movable, not copyable (the trees refer to the points); a moved-from index must not be used.
class PointIndex {
 public:
  PointIndex();
  ~PointIndex();
  PointIndex(PointIndex&&) noexcept;
  PointIndex& operator=(PointIndex&&) noexcept;
  PointIndex(const PointIndex&) = delete;
  PointIndex& operator=(const PointIndex&) = delete;

  /// Appends a point and returns its index (0, 1, 2, ... in order of addition). Throws
  /// std::invalid_argument for a non-finite point.
  std::size_t add(const Vec3d& p);
  /// Replaces every point (same indices) and rebuilds the trees, e.g. after a pose correction.
  /// Throws std::invalid_argument for a non-finite point.
  void reset(const std::vector<Vec3d>& points);

  std::size_t size() const;
  bool empty() const { return size() == 0; }
  const Vec3d& operator[](std::size_t i) const;

  /// Indices of the points p with (p.x - c.x)^2 + (p.y - c.y)^2 + (p.z - c.z)^2 <= radius^2
  /// (summed in that order), ascending. Throws std::invalid_argument for a negative or
  /// non-finite radius.
  std::vector<std::size_t> withinRadius(const Vec3d& centre, double radius_m) const;

 private:
  struct Trees;
  std::unique_ptr<Trees> trees_;
};

}  // namespace vdbmap::planner
