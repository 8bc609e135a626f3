// A 3D DDA (Amanatides & Woo) over unit cells (private to the library): the ray integrator walks
// voxels with it, the projective integrator leaves, and set-cover pruning coarse cells.
#pragma once

#include "vdbmap/types.hpp"

#include <cmath>
#include <limits>

namespace vdbmap::internal {

/// Walks the cells a ray crosses, in order. Cells live in an index space where cell c spans
/// [c, c + 1) per axis; the ray starts at `origin` (index space) and goes along the unit direction
/// `dir` (world), `cells_per_metre` index units per metre, so ray parameters t are in metres.
struct GridDda {
  int cell[3];       ///< the current cell
  int step[3];       ///< +1, -1 or 0 per axis
  double t_max[3];   ///< ray parameter of the next boundary per axis
  double t_delta[3]; ///< ray parameter between boundaries per axis

  GridDda(const Vec3d& origin, const Vec3d& dir, double cells_per_metre) {
    for (int a = 0; a < 3; ++a) {
      cell[a] = int(std::floor(origin[a]));
      const double g = dir[a] * cells_per_metre;
      if (g > 0.0) {
        step[a] = 1;
        t_max[a] = (cell[a] + 1 - origin[a]) / g;
        t_delta[a] = 1.0 / g;
      } else if (g < 0.0) {
        step[a] = -1;
        t_max[a] = (cell[a] - origin[a]) / g;
        t_delta[a] = -1.0 / g;
      } else {
        step[a] = 0;
        t_max[a] = t_delta[a] = std::numeric_limits<double>::infinity();
      }
    }
  }

  /// The axis whose boundary the ray crosses next (ties go to the lower axis).
  int nextAxis() const {
    const int a = t_max[1] < t_max[0] ? 1 : 0;
    return t_max[2] < t_max[a] ? 2 : a;
  }
  /// Moves into the next cell along axis a (from nextAxis()).
  void advance(int a) {
    cell[a] += step[a];
    t_max[a] += t_delta[a];
  }
};

}  // namespace vdbmap::internal
