#include "vdbmap/io/frame_source.hpp"

#include "vdbmap/io/ros_bag.hpp"

#include "vdbmap/io/errors.hpp"
#include "vdbmap/io/png_io.hpp"
#include "vdbmap/io/point_cloud_io.hpp"

#include "importers.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <new>
#include <sstream>
#include <stdexcept>

namespace vdbmap::io {

FrameSource::FrameSource(FrameSourceContents contents) : c_(std::move(contents)) {
  if (c_.sensor.kind == SensorKind::Depth) K_ = std::make_shared<const CameraIntrinsics>(c_.sensor.intrinsics);
  for (std::size_t i = 0; i < c_.records.size(); ++i) {
    if (c_.records[i].index != i)
      throw std::invalid_argument("FrameSource: record " + std::to_string(i) + " has index " + std::to_string(c_.records[i].index));
    if (i > 0 && !(c_.records[i].timestamp_s > c_.records[i - 1].timestamp_s))
      throw std::invalid_argument("FrameSource: timestamps must strictly increase (" + c_.records[i].source + ")");
  }
}

const FrameRecord& FrameSource::record(std::size_t i) const {
  if (i >= c_.records.size())
    throw std::out_of_range("FrameSource: frame " + std::to_string(i) + " out of range (" + std::to_string(size()) + " frames)");
  return c_.records[i];
}

std::optional<std::size_t> FrameSource::findFrame(double timestamp_s, double tolerance_s) const {
  const auto it = findStamp(c_.records.begin(), c_.records.end(), timestamp_s, tolerance_s);
  if (it == c_.records.end()) return std::nullopt;
  return std::size_t(it - c_.records.begin());
}

Frame FrameSource::load(std::size_t i) const {
  const FrameRecord& r = record(i);
  const std::string who = "frame " + std::to_string(i) + " (" + r.source + ")";
  if (!r.problem.empty()) throw BadFrameError(i, who + ": " + r.problem);
  std::string ext = r.file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return char(std::tolower(ch)); });
  Frame f;
  f.index = i;
  f.timestamp_s = r.timestamp_s;
  f.T_W_S = r.T_W_S;
  try {
    if (ext == ".png") {
      if (c_.sensor.kind != SensorKind::Depth) throw FileError(r.file.string() + ": a depth PNG, but the sensor is a point sensor");
      // The camera's size is checked against the PNG header before anything is decoded.
      const CameraIntrinsics& K = c_.sensor.intrinsics;
      f.data = SensorFrame::depth(
          readDepthPng(r.file, c_.sensor.depth_scale, c_.sensor.invalid_depth_raw, K.width, K.height), K_);
    } else if (ext == ".ply" || ext == ".pcd" || ext == ".bin") {
      f.data = SensorFrame::points(readPointCloud(r.file));
    } else {
      throw FileError(r.file.string() + ": unknown frame file type '" + ext + "' (expected .png, .ply, .pcd or .bin)");
    }
  } catch (const BadFrameError&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw BadFrameError(i, who + ": " + e.what());
  } catch (const std::bad_alloc&) {
    // The readers bound what they allocate by the file's size, so this is a frame too large for
    // the memory left: a bad frame too, which `--on-bad-frame skip` can skip.
    throw BadFrameError(i, who + ": out of memory reading " + r.file.string());
  }
  return f;
}

const char* toString(DatasetFormat format) {
  switch (format) {
    case DatasetFormat::Auto: return "auto";
    case DatasetFormat::Log: return "log";
    case DatasetFormat::SevenScenes: return "7scenes";
    case DatasetFormat::ThreeDMatch: return "3dmatch";
    case DatasetFormat::IclNuim: return "iclnuim";
    case DatasetFormat::Redwood: return "redwood";
    case DatasetFormat::Tum: return "tum";
    case DatasetFormat::Replica: return "replica";
  }
  return "unknown";
}

DatasetFormat parseDatasetFormat(const std::string& name) {
  for (DatasetFormat f : {DatasetFormat::Auto, DatasetFormat::Log, DatasetFormat::SevenScenes, DatasetFormat::ThreeDMatch,
                          DatasetFormat::IclNuim, DatasetFormat::Redwood, DatasetFormat::Tum, DatasetFormat::Replica})
    if (name == toString(f)) return f;
  throw std::invalid_argument("unknown dataset format '" + name +
                              "' (expected auto, log, 7scenes, 3dmatch, iclnuim, redwood, tum or replica)");
}

DatasetFormat detectDatasetFormat(const std::filesystem::path& path) {
  std::filesystem::path folder;
  try {
    return detail::detectLayout(path, folder);
  } catch (const std::runtime_error&) {
    return DatasetFormat::Auto;
  }
}

std::unique_ptr<FrameSource> openDataset(const std::filesystem::path& path, DatasetFormat format) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw FileError(path.string() + ": no such folder");
  std::filesystem::path folder = path;
  if (!std::filesystem::is_directory(path, ec)) {
    if (path.extension() == ".bag") return openRosBag(path);  // topics picked when unambiguous
    // A log's sensor.json or frames.csv names its folder.
    const std::string name = path.filename().string();
    if (name == "frames.csv" || name == "sensor.json") folder = path.parent_path();
    else throw FileError(path.string() + ": is a file; expected a log or dataset folder");
  }
  if (format == DatasetFormat::Auto) {
    std::filesystem::path resolved;
    format = detail::detectLayout(folder, resolved);
    if (format == DatasetFormat::Auto)
      throw FileError(
          folder.string() +
          ": not a recognised log or dataset: expected sensor.json + frames.csv (log), frame-XXXXXX.depth.png + "
          ".pose.txt (7-Scenes/3DMatch), pose.txt + depth/ (ICL-NUIM), depth/ + trajectory.log (Redwood), depth.txt + "
          "groundtruth.txt (TUM RGB-D) or traj.txt + results/ + cam_params.json (Replica)");
    folder = resolved;
  }
  // A forced format may still need the one sub-folder detection would pick (e.g. RGBD/ of
  // Open3D's test data, or the single seq-XX of a 3DMatch scene).
  {
    std::filesystem::path resolved;
    DatasetFormat detected = DatasetFormat::Auto;
    try {
      detected = detail::detectLayout(folder, resolved);
    } catch (const std::runtime_error&) {
      detected = DatasetFormat::Auto;
    }
    const auto family = [](DatasetFormat f) { return f == DatasetFormat::ThreeDMatch ? DatasetFormat::SevenScenes : f; };
    if (detected != DatasetFormat::Auto && family(detected) == family(format)) folder = resolved;
  }
  FrameSourceContents c;
  switch (format) {
    case DatasetFormat::Log: c = detail::readLog(folder); break;
    case DatasetFormat::SevenScenes:
    case DatasetFormat::ThreeDMatch: c = detail::importSevenScenes(folder, format); break;
    case DatasetFormat::IclNuim: c = detail::importIclNuim(folder); break;
    case DatasetFormat::Redwood: c = detail::importRedwood(folder); break;
    case DatasetFormat::Tum: c = detail::importTum(folder); break;
    case DatasetFormat::Replica: c = detail::importReplica(folder); break;
    case DatasetFormat::Auto: break;
  }
  return std::make_unique<FrameSource>(std::move(c));
}

}  // namespace vdbmap::io
