// One frame of sensor data, the one shape a frame has on its way into the map: a depth image with
// its camera, or points in the sensor frame S. Frame sources load it (io::Frame), the mapper takes
// it (Mapper::addFrame), the keyframe store encodes and decodes it (EncodedFrame), and the volume
// integrates it as its integrator takes each kind best (projective for depth, rays for points).
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/types.hpp"

#include <memory>

namespace vdbmap {

class SensorFrame {
 public:
  /// An empty point frame.
  SensorFrame() = default;
  /// A depth image (metres, 0 = invalid) seen by camera K. Throws std::invalid_argument when K is
  /// null or the image's size is not K's.
  static SensorFrame depth(DepthImage depth_m, std::shared_ptr<const CameraIntrinsics> K);
  /// Points in the sensor frame (NaN points are invalid).
  static SensorFrame points(PointCloud points_S);

  bool isDepth() const { return K_ != nullptr; }
  /// The depth image; throws std::logic_error for a point frame.
  const DepthImage& depthImage() const;
  /// The depth image's camera; throws std::logic_error for a point frame.
  const CameraIntrinsics& intrinsics() const;
  /// The camera as shared (frames of one sensor share one), nullptr for a point frame.
  const std::shared_ptr<const CameraIntrinsics>& sharedIntrinsics() const { return K_; }
  /// The points; throws std::logic_error for a depth frame.
  const PointCloud& points_S() const;

 private:
  DepthImage depth_m_;
  std::shared_ptr<const CameraIntrinsics> K_;
  PointCloud points_S_;
};

}  // namespace vdbmap
