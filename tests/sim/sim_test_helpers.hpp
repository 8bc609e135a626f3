// Helpers shared by the simulator tests: small triangle-mesh worlds built from boxes, and the
// shared worlds' paths.
#pragma once

#include "common/shared_data.hpp"
#include "vdbmap/sim/world.hpp"
#include "vdbmap/triangle_mesh.hpp"

#include <array>
#include <filesystem>

namespace vdbmap::test {

/// The AWS small house, embedded in data/worlds (always there).
inline std::filesystem::path houseMesh() { return embeddedWorld("small_house/small_house_visual_mesh.ply"); }
/// The AWS small warehouse from the shared data; the test case is skipped when it is missing.
inline std::filesystem::path warehouseMesh() {
  return requireSharedData("aws_small_warehouse_world/no_roof_small_warehouse_visual_mesh.ply");
}

/// Adds the 6 faces (12 triangles) of the box [lo, hi]; `skip_face` (0..5 = -x, +x, -y, +y, -z, +z)
/// leaves one face out, making an open box.
inline void addBox(TriangleMesh& mesh, const Vec3d& lo, const Vec3d& hi, int skip_face = -1) {
  const int base = int(mesh.vertices.size());
  for (int k = 0; k < 8; ++k)
    mesh.vertices.emplace_back(float(k & 1 ? hi.x() : lo.x()), float(k & 2 ? hi.y() : lo.y()),
                               float(k & 4 ? hi.z() : lo.z()));
  // Faces as quads of corner indices (bit 0 = x, bit 1 = y, bit 2 = z).
  const std::array<std::array<int, 4>, 6> faces = {
      {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}}};
  for (int f = 0; f < 6; ++f) {
    if (f == skip_face) continue;
    const auto& q = faces[std::size_t(f)];
    mesh.triangles.emplace_back(base + q[0], base + q[1], base + q[2]);
    mesh.triangles.emplace_back(base + q[0], base + q[2], base + q[3]);
  }
}

/// A closed room [lo, hi] (walls, floor, ceiling) with a box standing in it.
inline TriangleMesh roomWithBox(const Vec3d& lo = {-3, -2, 0}, const Vec3d& hi = {3, 2, 2.5}) {
  TriangleMesh mesh;
  addBox(mesh, lo, hi);
  addBox(mesh, {1.0, -1.5, 0.0}, {2.0, -0.5, 1.2});
  addBox(mesh, {-2.2, 0.8, 0.0}, {-1.6, 1.6, 1.8});
  return mesh;
}

}  // namespace vdbmap::test
