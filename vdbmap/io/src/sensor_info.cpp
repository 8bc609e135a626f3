#include "vdbmap/io/sensor_info.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/field_check.hpp"
#include "vdbmap/io/errors.hpp"

#include "text_util.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <stdexcept>

namespace vdbmap::io {

const char* toString(SensorKind kind) { return kind == SensorKind::Depth ? "depth" : "points"; }

void SensorInfo::validate() const {
  const FieldCheck check("SensorInfo");
  if (kind == SensorKind::Depth) {
    intrinsics.validate();
    if (!(depth_scale > 0.0 && depth_scale <= 1.0)) check.fail("depth_scale", "(0, 1] metres per unit", depth_scale);
  }
  if (!(max_range_m > 0.0 && max_range_m <= 1000.0)) check.fail("max_range_m", "(0, 1000]", max_range_m);
  if (!(min_range_m >= 0.0 && min_range_m < max_range_m)) check.fail("min_range_m", "[0, max_range_m)", min_range_m);
}

SensorInfo readSensorJson(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw FileError(path.string() + ": no such file");
  const std::string text = detail::readWholeFile(path);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    // Not only parse_error: a number beyond double's range ("1e1000") is an out_of_range, which
    // derives from std::exception alone.
    detail::fail(path, std::string("invalid JSON: ") + e.what());
  }
  if (!j.is_object()) detail::fail(path, "expected a JSON object");
  auto number = [&](const char* key, bool required, double fallback) -> double {
    if (!j.contains(key)) {
      if (required) detail::fail(path, std::string("missing key \"") + key + "\"");
      return fallback;
    }
    if (!j[key].is_number()) detail::fail(path, std::string("key \"") + key + "\" must be a number");
    return j[key].get<double>();
  };
  SensorInfo s;
  if (!j.contains("kind") || !j["kind"].is_string()) detail::fail(path, "missing string key \"kind\" (\"depth\" or \"points\")");
  const std::string kind = j["kind"].get<std::string>();
  if (kind == "depth") s.kind = SensorKind::Depth;
  else if (kind == "points") s.kind = SensorKind::Points;
  else detail::fail(path, "key \"kind\" must be \"depth\" or \"points\", got \"" + kind + "\"");
  if (s.kind == SensorKind::Depth) {
    auto integer = [&](const char* key) {
      const double v = number(key, true, 0);
      if (v != std::floor(v) || v < 1 || v > 1e6) detail::fail(path, std::string("key \"") + key + "\" must be a positive integer");
      return int(v);
    };
    s.intrinsics.width = integer("width");
    s.intrinsics.height = integer("height");
    s.intrinsics.fx = number("fx", true, 0);
    s.intrinsics.fy = number("fy", true, 0);
    s.intrinsics.cx = number("cx", true, 0);
    s.intrinsics.cy = number("cy", true, 0);
    s.depth_scale = number("depth_scale", true, 0);
    const double inv = number("depth_invalid_value", false, 0);
    if (inv < 0 || inv > 65535 || inv != std::floor(inv)) detail::fail(path, "key \"depth_invalid_value\" must be an integer in [0, 65535]");
    s.invalid_depth_raw = std::uint16_t(inv);
  }
  s.min_range_m = number("min_range_m", false, s.min_range_m);
  s.max_range_m = number("max_range_m", false, s.max_range_m);
  try {
    s.validate();
  } catch (const std::invalid_argument& e) {
    detail::fail(path, e.what());
  }
  return s;
}

void writeSensorJson(const std::filesystem::path& path, const SensorInfo& sensor) {
  sensor.validate();
  nlohmann::ordered_json j;
  j["kind"] = toString(sensor.kind);
  if (sensor.kind == SensorKind::Depth) {
    j["width"] = sensor.intrinsics.width;
    j["height"] = sensor.intrinsics.height;
    j["fx"] = sensor.intrinsics.fx;
    j["fy"] = sensor.intrinsics.fy;
    j["cx"] = sensor.intrinsics.cx;
    j["cy"] = sensor.intrinsics.cy;
    j["depth_scale"] = sensor.depth_scale;
    if (sensor.invalid_depth_raw != 0) j["depth_invalid_value"] = sensor.invalid_depth_raw;
  }
  j["min_range_m"] = sensor.min_range_m;
  j["max_range_m"] = sensor.max_range_m;
  writeFileAtomically(path, [&](std::ostream& out) { out << j.dump(2) << '\n'; });
}

}  // namespace vdbmap::io
