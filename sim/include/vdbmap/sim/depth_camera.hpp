// A simulated depth camera: renders a World's depth from a sensor pose. FUEL's simulated camera
// by default: 640x480, fx = fy = 387.229, 15 Hz, 0.1-5 m.
//
// A pixel's depth is the distance along the optical axis (z) to the first surface the ray through
// the pixel centre meets. Pixels that see nothing within range are 0 (invalid), as a real depth
// camera reports them; so are pixels whose nearest surface is closer than min_range_m. Optional
// Gaussian depth noise is seeded per (seed, frame, pixel), so an image does not depend on thread
// count or rendering order.
//
// render() rasterizes: every triangle is clipped at the near plane, projected, and its pixels
// (centres inside by watertight edge tests) take the exact depth where the pixel's ray meets the
// triangle's plane, nearest first (a z-buffer), in parallel over bands of rows (TBB).
// renderByRaycast() casts one ray per pixel through the World's hierarchy instead: the same image
// (to rounding, and up to ties exactly on a triangle edge), slower, and the reference in tests.
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/io/sensor_info.hpp"
#include "vdbmap/sim/world.hpp"
#include "vdbmap/types.hpp"

#include <cstdint>

namespace vdbmap::sim {

struct DepthCameraConfig {
  CameraIntrinsics intrinsics;  ///< 640x480, fx = fy = 387.229, principal point at the centre
  double rate_hz = 15.0;        ///< frames per second; (0, 1000]
  double min_range_m = 0.1;     ///< closer surfaces read 0; [0, max_range_m)
  double max_range_m = 5.0;     ///< the sensor's range, written to sensor.json; (min_range_m, 1000]
  /// Surfaces up to this distance along the ray are reported (beyond max_range_m the mapper then
  /// carves free space up to its range and adds no surface). Must be >= max_range_m; the default
  /// (= max_range_m) reports nothing beyond the sensor's range.
  double far_clip_m = 5.0;
  double noise_sigma_m = 0.0;  ///< Gaussian depth noise (0 = exact); [0, 1]
  std::uint64_t noise_seed = 1;
  /// Depth quantisation of the PNG files a log stores (metres per unit).
  double depth_scale_m = 0.001;  ///< (0, 0.1]

  void validate() const;
};

class DepthCamera {
 public:
  explicit DepthCamera(const DepthCameraConfig& config = {});

  const DepthCameraConfig& config() const { return config_; }
  const CameraIntrinsics& intrinsics() const { return config_.intrinsics; }
  double period_s() const { return 1.0 / config_.rate_hz; }

  /// Renders the depth image seen from T_W_S (OpenCV axes). `frame` seeds the noise.
  DepthImage render(const World& world, const Pose3d& T_W_S, std::uint64_t frame = 0) const;
  /// The same without noise, by one ray per pixel (the reference for render()).
  DepthImage renderByRaycast(const World& world, const Pose3d& T_W_S) const;

  /// The sensor description of a log recorded with this camera (kind depth).
  io::SensorInfo sensorInfo() const;

 private:
  DepthCameraConfig config_;
};

}  // namespace vdbmap::sim
