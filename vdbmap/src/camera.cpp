#include "vdbmap/camera.hpp"

#include "vdbmap/field_check.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

namespace vdbmap {

void CameraIntrinsics::validate() const {
  const FieldCheck check("CameraIntrinsics");
  check.inRange("width", width, 1, kMaxCameraSide);
  check.inRange("height", height, 1, kMaxCameraSide);
  if (!(fx > 0.0 && fx <= 1e7)) check.fail("fx", "(0, 1e7] pixels", fx);
  if (!(std::abs(fy) > 0.0 && std::abs(fy) <= 1e7)) check.fail("fy", "+-(0, 1e7] pixels (negative: flipped y axis)", fy);
  check.inRange("cx", cx, -1e7, 1e7);
  check.inRange("cy", cy, -1e7, 1e7);
}

void checkDepthImageSize(const DepthImage& depth, const CameraIntrinsics& K, const char* who) {
  K.validate();
  if (depth.width != K.width || depth.height != K.height ||
      depth.depth_m.size() != std::size_t(K.width) * std::size_t(K.height))
    throw std::invalid_argument(std::string(who ? who : "") + (who ? ": " : "") + "depth image is " +
                                std::to_string(depth.width) + "x" + std::to_string(depth.height) +
                                " but the camera is " + std::to_string(K.width) + "x" + std::to_string(K.height));
}

DepthImage depthFromRaw(int width, int height, const std::uint16_t* raw, double depth_scale,
                        std::uint16_t invalid_raw) {
  if (width < 0 || height < 0)
    throw std::invalid_argument("depthFromRaw: size must be >= 0, got " + std::to_string(width) + "x" +
                                std::to_string(height));
  if (!(depth_scale > 0.0) || !std::isfinite(depth_scale))
    throw std::invalid_argument("depthFromRaw: depth_scale must be finite and > 0, got " + std::to_string(depth_scale));
  DepthImage depth(width, height);
  const float scale = float(depth_scale);
  for (std::size_t i = 0; i < depth.depth_m.size(); ++i) {
    const std::uint16_t r = raw[i];
    depth.depth_m[i] = (r == 0 || (invalid_raw != 0 && r == invalid_raw)) ? 0.0f : float(r) * scale;
  }
  return depth;
}

PointCloud backProject(const DepthImage& depth, const CameraIntrinsics& K, int stride) {
  checkDepthImageSize(depth, K, "backProject");
  if (stride < 1) throw std::invalid_argument("backProject: stride must be >= 1, got " + std::to_string(stride));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  PointCloud points_S;
  points_S.reserve(std::size_t((K.width + stride - 1) / stride) * ((K.height + stride - 1) / stride));
  const double inv_fx = 1.0 / K.fx, inv_fy = 1.0 / K.fy;
  for (int v = 0; v < K.height; v += stride) {
    for (int u = 0; u < K.width; u += stride) {
      const float z = depth.at(u, v);
      if (!(z > 0.0f) || !std::isfinite(z)) {
        points_S.emplace_back(nan, nan, nan);
        continue;
      }
      points_S.push_back(backProjectPixel(u, v, z, K, inv_fx, inv_fy));
    }
  }
  return points_S;
}

Pose3d lookingPose(const Vec3d& position_W, double yaw, double pitch) {
  // Optical frame: z forward, x right, y down. Forward = (cos yaw cos pitch, sin yaw cos pitch, -sin pitch).
  const Vec3d forward(std::cos(yaw) * std::cos(pitch), std::sin(yaw) * std::cos(pitch), -std::sin(pitch));
  const Vec3d right = forward.cross(Vec3d::UnitZ()).normalized();
  const Vec3d down = forward.cross(right);
  Pose3d T = Pose3d::Identity();
  T.linear().col(0) = right;
  T.linear().col(1) = down;
  T.linear().col(2) = forward;
  T.translation() = position_W;
  return T;
}

}  // namespace vdbmap
