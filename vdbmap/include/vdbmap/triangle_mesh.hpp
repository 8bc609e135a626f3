// An indexed triangle mesh: what mesh extraction produces, what worlds and ground truth are.
#pragma once

#include "vdbmap/types.hpp"

#include <Eigen/Core>

#include <vector>

namespace vdbmap {

struct TriangleMesh {
  std::vector<Vec3f> vertices;            ///< metres, in the world frame unless said otherwise
  std::vector<Eigen::Vector3i> triangles;  ///< indices into `vertices`, counter-clockwise = front
};

}  // namespace vdbmap
