// Compact storage of integrated frames, so the map can de-integrate and re-integrate them later.
//
// A frame is stored quantized and compressed (depth images: 16-bit depth in `depth_unit_m`
// steps, row-delta coded and zlib-compressed; point clouds: 32-bit integer coordinates in
// `point_unit_m` steps, zlib-compressed). The mapper integrates the *decoded* frame, so what it
// later de-integrates is bit-identical to what it integrated. (It compresses a new frame on a
// worker thread and holds it raw meanwhile: a raw and a compressed frame decode alike.)
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/sensor_frame.hpp"
#include "vdbmap/types.hpp"

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace vdbmap {

class AtomicFileSet;

/// One frame's sensor data, quantized and compressed.
class EncodedFrame {
 public:
  EncodedFrame() = default;
  /// Depth in metres quantized to `depth_unit_m` (depths beyond 65535 units are clamped there,
  /// which keeps them beyond any sensible max range); invalid pixels stay invalid. `compress`
  /// false skips zlib (for frames decoded once and not stored); decode() gives the same points.
  static EncodedFrame fromDepth(const DepthImage& depth, std::shared_ptr<const CameraIntrinsics> K,
                                double depth_unit_m = 0.001, int stride = 1, bool compress = true);
  /// Points in the sensor frame quantized to `unit_m`; NaN points are kept as invalid.
  static EncodedFrame fromPoints(const PointCloud& points_S, double unit_m = 0.001, bool compress = true);
  /// fromDepth (stride 1) or fromPoints, as the frame is.
  static EncodedFrame encode(const SensorFrame& frame, double unit_m = 0.001, bool compress = true);
  /// encode() without zlib, and its decodeFrame() into `decoded`, in one pass.
  static EncodedFrame encodeRaw(const SensorFrame& frame, double unit_m, SensorFrame& decoded);
  /// What decodeFrame() of encode(frame, unit_m) gives, without the codes: the frame as a mapper
  /// that keeps no frames integrates it.
  static SensorFrame quantize(const SensorFrame& frame, double unit_m = 0.001);

  /// The frame exactly as every other decode gives it: a depth image with its camera when
  /// isDepth(), else points (those of a strided depth frame too).
  SensorFrame decodeFrame() const;

  /// The frame's points in the sensor frame, exactly as every other decode of this frame.
  PointCloud decode() const;
  /// Whether the frame is a depth image (decodeDepth() works) rather than points.
  bool isDepth() const { return kind_ == Kind::Depth && stride_ == 1; }
  /// The depth image (metres, 0 = invalid), exactly as every other decode; its points are
  /// decode()'s. Throws std::logic_error for point frames (see isDepth()).
  DepthImage decodeDepth() const;
  /// The camera of a depth frame (nullptr for points).
  const std::shared_ptr<const CameraIntrinsics>& intrinsics() const { return intrinsics_; }
  /// Whether the payload is zlib-compressed (else it holds the raw codes).
  bool isCompressed() const { return compressed_; }
  /// This frame with its payload zlib-compressed (a copy when it already is). It decodes exactly
  /// as this one, and its bytes are those of encoding with `compress` true, so a frame may be
  /// encoded raw for integration and compressed later, e.g. on another thread.
  EncodedFrame compressed() const;
  /// Bytes held (compressed payload plus bookkeeping).
  std::size_t bytes() const { return sizeof(*this) + payload_.capacity(); }
  bool empty() const { return payload_.empty(); }

 private:
  friend struct KeyframeStoreFile;  // keyframe_store_io.cpp reads and writes the fields
  /// fromDepth, also writing decodeDepth() of the result into *decoded when given (same size).
  static EncodedFrame depthFrame(const DepthImage& depth, std::shared_ptr<const CameraIntrinsics> K,
                                 double depth_unit_m, int stride, bool compress, DepthImage* decoded);
  enum class Kind : std::uint8_t { Depth, Points };
  Kind kind_ = Kind::Points;
  std::shared_ptr<const CameraIntrinsics> intrinsics_;
  double unit_m_ = 0.001;
  int stride_ = 1;
  std::uint32_t count_ = 0;  ///< pixels or points
  bool compressed_ = true;   ///< payload_ is zlib-compressed (else the raw codes)
  std::vector<std::uint8_t> payload_;
};

/// A stored keyframe: its data and both poses.
struct Keyframe {
  FrameId id = 0;
  double timestamp = 0.0;
  Pose3d T_W_S_integrated = Pose3d::Identity();  ///< the pose the map currently holds it at
  Pose3d T_W_S_latest = Pose3d::Identity();      ///< the newest estimate (odometry or correction)
  bool integrated = false;                       ///< whether the map currently holds it
  EncodedFrame data;
};

class KeyframeStore {
 public:
  /// Adds a keyframe; throws std::invalid_argument when the id is already stored.
  Keyframe& add(Keyframe keyframe);
  /// Throws std::out_of_range naming the id when it is not stored.
  Keyframe& at(FrameId id);
  const Keyframe& at(FrameId id) const;
  bool contains(FrameId id) const { return frames_.count(id) != 0; }
  void erase(FrameId id) { frames_.erase(id); }
  std::size_t size() const { return frames_.size(); }
  /// Bytes held by all stored frames.
  std::size_t bytes() const;

  auto begin() const { return frames_.begin(); }
  auto end() const { return frames_.end(); }
  auto begin() { return frames_.begin(); }
  auto end() { return frames_.end(); }

  // ---- files (keyframe_store_io.cpp) ---------------------------------------------------------
  /// Writes every keyframe (ids, stamps, both poses, whether integrated, the encoded data as
  /// stored) to `path` (docs/formats.md, "MAP.keyframes"), atomically: a failure leaves an
  /// existing file untouched. Throws FileError naming the file.
  void save(const std::filesystem::path& path) const;
  /// save() into a set the caller commits, under the set's unit id (Mapper::save: with its map).
  void stageSave(const std::filesystem::path& path, AtomicFileSet& files) const;
  /// The unit id in the file's header ("" for version 1 stores). Throws FileError as load().
  static std::string savedUnitId(const std::filesystem::path& path);
  /// Reads a file save() wrote. Throws FileError naming the file, the keyframe and the field on
  /// bad input (wrong magic, newer version, sizes beyond the file, invalid camera or pose), before
  /// allocating for sizes the file cannot hold.
  static KeyframeStore load(const std::filesystem::path& path);

 private:
  std::map<FrameId, Keyframe> frames_;
};

}  // namespace vdbmap
