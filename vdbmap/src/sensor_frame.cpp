#include "vdbmap/sensor_frame.hpp"

#include <stdexcept>
#include <string>

namespace vdbmap {

SensorFrame SensorFrame::depth(DepthImage depth_m, std::shared_ptr<const CameraIntrinsics> K) {
  if (!K) throw std::invalid_argument("SensorFrame::depth: intrinsics are required");
  if (depth_m.width != K->width || depth_m.height != K->height ||
      depth_m.depth_m.size() != std::size_t(depth_m.width) * std::size_t(depth_m.height))
    throw std::invalid_argument("SensorFrame::depth: image is " + std::to_string(depth_m.width) + "x" +
                                std::to_string(depth_m.height) + " with " + std::to_string(depth_m.depth_m.size()) +
                                " values, camera is " + std::to_string(K->width) + "x" + std::to_string(K->height));
  SensorFrame f;
  f.depth_m_ = std::move(depth_m);
  f.K_ = std::move(K);
  return f;
}

SensorFrame SensorFrame::points(PointCloud points_S) {
  SensorFrame f;
  f.points_S_ = std::move(points_S);
  return f;
}

const DepthImage& SensorFrame::depthImage() const {
  if (!isDepth()) throw std::logic_error("SensorFrame::depthImage: a point frame");
  return depth_m_;
}

const CameraIntrinsics& SensorFrame::intrinsics() const {
  if (!isDepth()) throw std::logic_error("SensorFrame::intrinsics: a point frame");
  return *K_;
}

const PointCloud& SensorFrame::points_S() const {
  if (isDepth()) throw std::logic_error("SensorFrame::points_S: a depth frame");
  return points_S_;
}

}  // namespace vdbmap
