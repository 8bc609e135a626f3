// Analytic scenes: surfaces with exact ray intersection and exact distance, for tests, the
// synthetic demo and benchmarks (ground truth without meshes or sampling error).
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/types.hpp"

#include <limits>
#include <vector>

namespace vdbmap::testing {

/// One analytic surface.
struct Primitive {
  enum class Kind {
    Plane,   ///< infinite plane through `a` with unit normal `b`
    Sphere,  ///< centre `a`, radius `radius`
    Box,     ///< solid axis-aligned box from corner `a` to corner `b`
    Room,    ///< the inside faces of an axis-aligned box from `a` to `b` (walls, floor, ceiling)
  };
  Kind kind = Kind::Plane;
  Vec3d a = Vec3d::Zero();
  Vec3d b = Vec3d::UnitZ();
  double radius = 0.0;
};

class AnalyticScene {
 public:
  AnalyticScene& addPlane(const Vec3d& point, const Vec3d& normal);
  AnalyticScene& addSphere(const Vec3d& centre, double radius);
  AnalyticScene& addBox(const Vec3d& min_corner, const Vec3d& max_corner);
  AnalyticScene& addRoom(const Vec3d& min_corner, const Vec3d& max_corner);

  /// Distance along the unit direction `dir_W` to the first surface hit (t > 0), or +inf.
  double raycast(const Vec3d& origin_W, const Vec3d& dir_W) const;
  /// Unsigned distance from p_W to the nearest surface.
  double distance(const Vec3d& p_W) const;
  /// Renders depth along the optical axis (0 where nothing is hit within max_range_m).
  DepthImage renderDepth(const CameraIntrinsics& K, const Pose3d& T_W_S, double max_range_m) const;

  const std::vector<Primitive>& primitives() const { return primitives_; }

  /// The built-in demo scene: a 8 x 6 x 3 m room with a sphere, two boxes and a table-like slab.
  static AnalyticScene demoRoom();
  /// Camera poses circling inside demoRoom() at 1.2 m height, looking around the room.
  static std::vector<Pose3d> demoTrajectory(int frames);

 private:
  std::vector<Primitive> primitives_;
};

}  // namespace vdbmap::testing
