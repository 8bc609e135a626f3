// Writes our log format (docs/formats.md): sensor.json, frames.csv, frame files, corrections/
// and groundtruth.txt. The simulator records its flights through it.
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/io/sensor_info.hpp"
#include "vdbmap/io/tum_trajectory.hpp"
#include "vdbmap/types.hpp"

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace vdbmap::io {

struct LogWriterConfig {
  /// Extension of point frames: ".bin" (raw float32 xyz), ".ply" or ".pcd".
  std::string points_extension = ".bin";
  /// Rewrite frames.csv (atomically) every this many frames, so a crash loses at most this many
  /// listings; 0 = only at flush()/close(). Must be >= 0.
  std::size_t flush_every_frames = 100;
  /// Allow writing into a folder that already holds a frames.csv (its frames.csv is replaced, and
  /// its corrections/ and groundtruth.txt are removed, since they name the old frames).
  bool overwrite = false;

  void validate() const;
};
using LogWriterOptions [[deprecated("renamed LogWriterConfig")]] = LogWriterConfig;

class LogWriter {
 public:
  /// Creates `folder` (and parents) and writes sensor.json. Throws std::invalid_argument on an
  /// invalid sensor or options, std::runtime_error when the folder already holds a log and
  /// overwrite is false, or on a write error.
  LogWriter(const std::filesystem::path& folder, const SensorInfo& sensor, LogWriterConfig options = {});
  /// Calls close(); errors are swallowed here, so call close() yourself to see them.
  ~LogWriter();
  LogWriter(const LogWriter&) = delete;
  LogWriter& operator=(const LogWriter&) = delete;

  /// Writes depth/<index>.png (16-bit, the sensor's depth_scale) and lists the frame. Throws
  /// std::invalid_argument for a non-depth sensor, a size differing from the intrinsics, a
  /// timestamp not greater than the previous one, or an invalid pose. Returns the frame index.
  std::size_t addDepthFrame(double timestamp_s, const DepthImage& depth_m, const Pose3d& T_W_S);
  /// Writes points/<index><points_extension> and lists the frame; same checks (sensor kind points).
  std::size_t addPointsFrame(double timestamp_s, const PointCloud& points_S, const Pose3d& T_W_S);

  /// Writes corrections/<event_timestamp>.txt. The event time and every pose's time must be
  /// those of frames already added (std::invalid_argument otherwise); poses must be valid.
  void addCorrection(double event_timestamp_s, const std::vector<StampedPose>& poses);

  /// Adds a true pose for groundtruth.txt (written at flush/close); timestamps increasing.
  void addGroundTruth(double timestamp_s, const Pose3d& T_W_S);

  /// Rewrites frames.csv (and groundtruth.txt when there is ground truth) atomically.
  void flush();
  /// flush() and stop; further adds throw std::logic_error. Idempotent.
  void close();

  std::size_t size() const { return frames_.size(); }
  const std::filesystem::path& folder() const { return folder_; }

 private:
  struct Listed {
    double timestamp_s;
    std::string file;  // relative to the folder
    Pose3d T_W_S;
  };
  void checkNewFrame(double timestamp_s, const Pose3d& T_W_S, const char* what) const;
  std::size_t list(double timestamp_s, const std::string& file, const Pose3d& T_W_S);
  bool hasFrameAt(double timestamp_s) const;

  std::filesystem::path folder_;
  SensorInfo sensor_;
  LogWriterConfig options_;
  std::vector<Listed> frames_;
  std::vector<StampedPose> ground_truth_;
  bool closed_ = false;
};

}  // namespace vdbmap::io
