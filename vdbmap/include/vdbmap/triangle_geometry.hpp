// Exact point-to-triangle geometry, shared by surface evaluation (eval.hpp) and the simulator's
// worlds (nearest-surface distances against ground-truth meshes).
#pragma once

#include "vdbmap/types.hpp"

#include <cmath>

namespace vdbmap {

/// The point of triangle (a, b, c) closest to p, found by the Voronoi regions of its vertices,
/// edges and face. A degenerate triangle (zero area) falls back to its nearest feature that the
/// region tests reach, at worst vertex a; the result is always a point of the triangle's hull.
inline Vec3d closestPointOnTriangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Vec3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = va + vb + vc;
  if (!(std::abs(denom) > 0)) return a;  // degenerate triangle: fall back to a vertex
  return a + ab * (vb / denom) + ac * (vc / denom);
}

}  // namespace vdbmap
