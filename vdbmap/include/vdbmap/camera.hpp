// Pinhole depth cameras: intrinsics, depth images, and back-projection to sensor-frame points.
//
// Axes follow OpenCV: x right, y down, z forward. A pixel (u, v) with depth z (metres, along the
// optical axis) is the point ((u - cx) z / fx, (v - cy) z / fy, z). Pixel centres are at integer
// (u, v). fy may be negative (ICL-NUIM's convention flips the image's y axis).
#pragma once

#include "vdbmap/types.hpp"

#include <cstdint>
#include <vector>

namespace vdbmap {

/// The largest image side a camera may have (pixels).
inline constexpr int kMaxCameraSide = 65536;

struct CameraIntrinsics {
  int width = 640;
  int height = 480;
  double fx = 387.229;  ///< focal length in pixels, > 0; FUEL's simulated camera by default
  double fy = 387.229;  ///< may be negative (flipped y axis), never zero
  double cx = 320.0;
  double cy = 240.0;

  /// Throws std::invalid_argument naming the field when a value is out of range: sides in
  /// [1, kMaxCameraSide], fx in (0, 1e7], |fy| in (0, 1e7], |cx|, |cy| <= 1e7.
  void validate() const;
};

/// A depth image in metres along the optical axis; 0 or NaN marks an invalid pixel.
struct DepthImage {
  int width = 0;
  int height = 0;
  std::vector<float> depth_m;  ///< row-major, size width * height

  DepthImage() = default;
  DepthImage(int w, int h, float fill = 0.0f) : width(w), height(h), depth_m(std::size_t(w) * h, fill) {}
  float& at(int u, int v) { return depth_m[std::size_t(v) * width + u]; }
  float at(int u, int v) const { return depth_m[std::size_t(v) * width + u]; }
};

/// Throws std::invalid_argument when K is invalid (CameraIntrinsics::validate) or `depth` is not
/// an image of K's size (naming both sizes, after "who: " when `who` is given).
void checkDepthImageSize(const DepthImage& depth, const CameraIntrinsics& K, const char* who = nullptr);

/// Depth in metres from raw sensor units (e.g. a 16-bit PNG or a uint16 array): depth_m = raw *
/// depth_scale, with depth_scale in metres per unit, computed in float as readDepthPng does, so
/// both give bit-identical images. Raw 0, and `invalid_raw` when it is non-zero (7-Scenes marks
/// missing depth 65535), become 0 = invalid. `raw` holds width * height values, row-major.
/// Throws std::invalid_argument when a size is negative or depth_scale is not finite and > 0.
DepthImage depthFromRaw(int width, int height, const std::uint16_t* raw, double depth_scale,
                        std::uint16_t invalid_raw = 0);

/// Back-projects every pixel to a point in the sensor frame. Invalid pixels (0, NaN, negative)
/// become NaN points so that the integrator counts them; `stride` keeps every stride-th pixel in
/// both directions. Throws std::invalid_argument when the image size differs from the intrinsics.
PointCloud backProject(const DepthImage& depth, const CameraIntrinsics& K, int stride = 1);

/// x rounded to float, and kept rounded. GCC 12 (C++, whose only excess-precision mode is "fast")
/// was seen to drop the rounding of float(x) when the float went straight back to double in
/// registers (Eigen's cast<double>()), so a point computed from a pixel in a loop differed from
/// the same point stored in a cloud. The empty asm makes the float a value the compiler must hold.
inline float keptFloat(double x) {
  float f = float(x);
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
  asm("" : "+x"(f));
#elif defined(__GNUC__)
  asm("" : "+m"(f));
#endif
  return f;
}

/// The point backProject() makes of pixel (u, v) with a valid depth z, for code that walks an
/// image without the cloud: the very same float whichever path computes it. inv_fx = 1 / K.fx,
/// inv_fy = 1 / K.fy.
inline Vec3f backProjectPixel(int u, int v, float z, const CameraIntrinsics& K, double inv_fx, double inv_fy) {
  return Vec3f(keptFloat((u - K.cx) * inv_fx * z), keptFloat((v - K.cy) * inv_fy * z), z);
}

/// A camera pose T_W_S at `position_W` whose optical axis (z) points along yaw in the x-y plane
/// (yaw 0 = world +x), with the image's y axis pointing down (world -z) and pitched by `pitch`
/// (radians; positive looks down).
Pose3d lookingPose(const Vec3d& position_W, double yaw, double pitch = 0.0);

}  // namespace vdbmap
