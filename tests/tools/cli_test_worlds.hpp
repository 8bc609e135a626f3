// Tiny worlds for the CLI tests (written to PLY by the tests).
#pragma once

#include "vdbmap/triangle_mesh.hpp"

namespace vdbmap::test {

/// A closed 5 x 4 x 2.5 m room with a box standing in it (walls, floor and ceiling).
inline TriangleMesh roomWithBox() {
  TriangleMesh m;
  auto box = [&m](float x0, float y0, float z0, float x1, float y1, float z1) {
    const int base = int(m.vertices.size());
    for (int k = 0; k < 8; ++k) m.vertices.emplace_back(k & 1 ? x1 : x0, k & 2 ? y1 : y0, k & 4 ? z1 : z0);
    const int quads[6][4] = {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}};
    for (const auto& q : quads) {
      m.triangles.emplace_back(base + q[0], base + q[1], base + q[2]);
      m.triangles.emplace_back(base + q[0], base + q[2], base + q[3]);
    }
  };
  box(-2.5f, -2.0f, 0.0f, 2.5f, 2.0f, 2.5f);
  box(1.0f, -1.5f, 0.0f, 1.8f, -0.7f, 1.0f);
  return m;
}

}  // namespace vdbmap::test
