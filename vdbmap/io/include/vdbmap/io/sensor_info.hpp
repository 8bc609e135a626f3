// What a log's sensor is: sensor.json of the log format (docs/formats.md).
#pragma once

#include "vdbmap/camera.hpp"

#include <cstdint>
#include <filesystem>
#include <string>

namespace vdbmap::io {

enum class SensorKind { Depth, Points };

/// The sensor of a log or dataset. Defaults are those of sensor.json's example in DESIGN.md.
struct SensorInfo {
  SensorKind kind = SensorKind::Depth;
  CameraIntrinsics intrinsics;   ///< depth sensors only (width, height, fx, fy, cx, cy)
  double depth_scale = 0.001;    ///< metres per depth unit of the PNG files, > 0 (depth only)
  std::uint16_t invalid_depth_raw = 0;  ///< a raw value meaning "no depth" besides 0 (7-Scenes: 65535); 0 = none
  double min_range_m = 0.1;      ///< >= 0
  double max_range_m = 5.0;      ///< > min_range_m

  /// Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};

const char* toString(SensorKind kind);

/// Reads sensor.json: "kind" ("depth" or "points", required); for depth "width", "height",
/// "fx", "fy", "cx", "cy", "depth_scale" (required) and "depth_invalid_value" (optional);
/// "min_range_m", "max_range_m" (optional, defaults above). Unknown keys are ignored. Throws
/// std::runtime_error naming the file (and JSON position or key) on malformed or invalid content.
SensorInfo readSensorJson(const std::filesystem::path& path);

/// Writes sensor.json atomically; throws std::invalid_argument when `sensor` is invalid.
void writeSensorJson(const std::filesystem::path& path, const SensorInfo& sensor);

}  // namespace vdbmap::io
