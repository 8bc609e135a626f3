// A bounding volume hierarchy over triangles: exact first-hit ray casting and nearest-surface
// distance for the simulator's World. Private to sim/.
//
// Binary tree of axis-aligned boxes built top-down with the surface area heuristic over 16
// centroid bins per axis; leaves hold at most kMaxLeafTriangles triangles. Boxes and triangles are
// stored in float (32-byte nodes, 36-byte triangles) for cache efficiency: at the metre scale of
// indoor worlds, float rounding moves a hit by micrometres.
#pragma once

#include "vdbmap/types.hpp"

#include <cstdint>
#include <limits>
#include <vector>

namespace vdbmap::sim::internal {

class TriangleBvh {
 public:
  struct Hit {
    double t = std::numeric_limits<double>::infinity();
    int triangle = -1;  ///< index in the order the triangles were given
  };

  /// Builds over triangles given by their three corners; none may be degenerate (the caller
  /// filters). The triangles' indices are their positions in `corners` / 3.
  explicit TriangleBvh(const std::vector<Vec3d>& corners);

  /// First hit along the unit direction with 1e-9 < t <= t_max (both faces count).
  Hit raycast(const Vec3d& origin, const Vec3d& dir, double t_max) const;
  /// Squared distance to the nearest triangle if below max_distance2, else max_distance2.
  double distance2(const Vec3d& p, double max_distance2) const;

  std::size_t nodes() const { return nodes_.size(); }
  int depth() const { return depth_; }

 private:
  static constexpr int kMaxLeafTriangles = 4;
  struct Node {
    float lo[3], hi[3];
    std::uint32_t first;  ///< leaf: first triangle; inner: right child (left child = this + 1)
    std::uint32_t count;  ///< leaf: triangle count; inner: 0
  };
  struct Tri {
    float a[3], e1[3], e2[3];
  };
  std::uint32_t build(std::uint32_t begin, std::uint32_t end, std::vector<float>& centroids, int depth);

  std::vector<Node> nodes_;
  std::vector<Tri> tris_;       ///< in leaf order
  std::vector<int> tri_index_;  ///< leaf order -> original index
  int depth_ = 0;
};

}  // namespace vdbmap::sim::internal
