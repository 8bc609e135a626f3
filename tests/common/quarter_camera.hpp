// A small depth camera for tests that render or pool depth themselves.
#pragma once

#include "vdbmap/camera.hpp"

namespace vdbmap::test {

/// The default camera's field of view (80 x 60 deg) at a quarter of its resolution: 160 x 120
/// pixels, principal point at the image's centre.
inline CameraIntrinsics quarterCamera() {
  CameraIntrinsics K;
  K.width = 160;
  K.height = 120;
  K.fx = K.fy = 387.229 / 4.0;
  K.cx = 79.5;
  K.cy = 59.5;
  return K;
}

}  // namespace vdbmap::test
