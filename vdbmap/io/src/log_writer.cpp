#include "vdbmap/io/log_writer.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/io/errors.hpp"
#include "vdbmap/io/png_io.hpp"
#include "vdbmap/io/point_cloud_io.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace vdbmap::io {

void LogWriterConfig::validate() const {
  if (points_extension != ".bin" && points_extension != ".ply" && points_extension != ".pcd")
    throw std::invalid_argument("LogWriterConfig: points_extension must be .bin, .ply or .pcd, got '" + points_extension + "'");
}

LogWriter::LogWriter(const std::filesystem::path& folder, const SensorInfo& sensor, LogWriterConfig options)
    : folder_(folder), sensor_(sensor), options_(std::move(options)) {
  sensor_.validate();
  options_.validate();
  std::error_code ec;
  if (std::filesystem::exists(folder_ / "frames.csv", ec)) {
    if (!options_.overwrite)
      throw FileError(folder_.string() + ": already holds a log (frames.csv); choose another folder or allow overwrite");
    // The old log's corrections and ground truth name the old frames: they must not apply to the new ones.
    std::filesystem::remove_all(folder_ / "corrections", ec);
    std::filesystem::remove(folder_ / "groundtruth.txt", ec);
    if (ec) throw FileError("cannot remove the old corrections of " + folder_.string() + ": " + ec.message());
  }
  std::filesystem::create_directories(folder_, ec);
  if (ec) throw FileError("cannot create " + folder_.string() + ": " + ec.message());
  writeSensorJson(folder_ / "sensor.json", sensor_);
}

LogWriter::~LogWriter() {
  try {
    close();
  } catch (...) {
    // Destructors must not throw; close() explicitly to see errors.
  }
}

void LogWriter::checkNewFrame(double timestamp_s, const Pose3d& T_W_S, const char* what) const {
  if (closed_) throw std::logic_error(std::string("LogWriter::") + what + ": the log is closed");
  if (!std::isfinite(timestamp_s))
    throw std::invalid_argument(std::string("LogWriter::") + what + ": timestamp must be finite");
  // Compare as written (6 decimals): two frames must stay distinct in frames.csv.
  if (!frames_.empty() && !(std::stod(formatTimestamp(timestamp_s)) > frames_.back().timestamp_s))
    throw std::invalid_argument(std::string("LogWriter::") + what + ": timestamp " + formatTimestamp(timestamp_s) +
                                " is not greater than the previous frame's " + formatTimestamp(frames_.back().timestamp_s));
  if (!isValidRigidTransform(T_W_S))
    throw std::invalid_argument(std::string("LogWriter::") + what + ": T_W_S of frame " + std::to_string(frames_.size()) +
                                " is not a valid rigid transform");
}

std::size_t LogWriter::list(double timestamp_s, const std::string& file, const Pose3d& T_W_S) {
  frames_.push_back({std::stod(formatTimestamp(timestamp_s)), file, T_W_S});
  if (options_.flush_every_frames > 0 && frames_.size() % options_.flush_every_frames == 0) flush();
  return frames_.size() - 1;
}

std::size_t LogWriter::addDepthFrame(double timestamp_s, const DepthImage& depth_m, const Pose3d& T_W_S) {
  checkNewFrame(timestamp_s, T_W_S, "addDepthFrame");
  if (sensor_.kind != SensorKind::Depth) throw std::invalid_argument("LogWriter::addDepthFrame: the log's sensor is a point sensor");
  if (depth_m.width != sensor_.intrinsics.width || depth_m.height != sensor_.intrinsics.height)
    throw std::invalid_argument("LogWriter::addDepthFrame: depth image is " + std::to_string(depth_m.width) + "x" +
                                std::to_string(depth_m.height) + " but the sensor is " + std::to_string(sensor_.intrinsics.width) +
                                "x" + std::to_string(sensor_.intrinsics.height));
  char name[64];
  std::snprintf(name, sizeof(name), "depth/%06zu.png", frames_.size());
  std::error_code ec;
  std::filesystem::create_directories(folder_ / "depth", ec);
  writeDepthPng(folder_ / name, depth_m, sensor_.depth_scale);
  return list(timestamp_s, name, T_W_S);
}

std::size_t LogWriter::addPointsFrame(double timestamp_s, const PointCloud& points_S, const Pose3d& T_W_S) {
  checkNewFrame(timestamp_s, T_W_S, "addPointsFrame");
  if (sensor_.kind != SensorKind::Points) throw std::invalid_argument("LogWriter::addPointsFrame: the log's sensor is a depth camera");
  char name[64];
  std::snprintf(name, sizeof(name), "points/%06zu%s", frames_.size(), options_.points_extension.c_str());
  std::error_code ec;
  std::filesystem::create_directories(folder_ / "points", ec);
  writePointCloud(folder_ / name, points_S);
  return list(timestamp_s, name, T_W_S);
}

bool LogWriter::hasFrameAt(double timestamp_s) const {
  const double t = std::stod(formatTimestamp(timestamp_s));
  for (auto it = frames_.rbegin(); it != frames_.rend(); ++it)
    if (std::abs(it->timestamp_s - t) < 1e-7) return true;
  return false;
}

void LogWriter::addCorrection(double event_timestamp_s, const std::vector<StampedPose>& poses) {
  if (closed_) throw std::logic_error("LogWriter::addCorrection: the log is closed");
  if (!hasFrameAt(event_timestamp_s))
    throw std::invalid_argument("LogWriter::addCorrection: event timestamp " + formatTimestamp(event_timestamp_s) +
                                " is not the timestamp of a frame already added");
  if (poses.empty()) throw std::invalid_argument("LogWriter::addCorrection: no pose");
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const double t = std::stod(formatTimestamp(poses[k].timestamp_s));  // as the file will hold it
    if (frames_.empty() || t < frames_.front().timestamp_s - 1e-7 || t > std::stod(formatTimestamp(event_timestamp_s)) + 1e-7)
      throw std::invalid_argument("LogWriter::addCorrection: pose " + std::to_string(k) + " at " + formatTimestamp(poses[k].timestamp_s) +
                                  " is outside the frames up to the event (the odometry is unknown there)");
    if (!isValidRigidTransform(poses[k].T_W_S))
      throw std::invalid_argument("LogWriter::addCorrection: pose " + std::to_string(k) + " is not a valid rigid transform");
    if (k > 0 && !(poses[k].timestamp_s > poses[k - 1].timestamp_s))
      throw std::invalid_argument("LogWriter::addCorrection: pose timestamps must increase");
  }
  std::error_code ec;
  std::filesystem::create_directories(folder_ / "corrections", ec);
  writeTumTrajectory(folder_ / "corrections" / (formatTimestamp(event_timestamp_s) + ".txt"), poses);
}

void LogWriter::addGroundTruth(double timestamp_s, const Pose3d& T_W_S) {
  if (closed_) throw std::logic_error("LogWriter::addGroundTruth: the log is closed");
  if (!ground_truth_.empty() && !(timestamp_s > ground_truth_.back().timestamp_s))
    throw std::invalid_argument("LogWriter::addGroundTruth: timestamps must increase");
  if (!isValidRigidTransform(T_W_S)) throw std::invalid_argument("LogWriter::addGroundTruth: not a valid rigid transform");
  ground_truth_.push_back({timestamp_s, T_W_S});
}

void LogWriter::flush() {
  writeFileAtomically(folder_ / "frames.csv", [&](std::ostream& out) {
    out << "timestamp,file,tx,ty,tz,qx,qy,qz,qw\n";
    char buf[512];
    for (const Listed& f : frames_) {
      const Eigen::Quaterniond q(f.T_W_S.linear());
      const Vec3d& t = f.T_W_S.translation();
      std::snprintf(buf, sizeof(buf), "%s,%s,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", formatTimestamp(f.timestamp_s).c_str(),
                    f.file.c_str(), t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
      out << buf;
    }
  });
  if (!ground_truth_.empty()) writeTumTrajectory(folder_ / "groundtruth.txt", ground_truth_);
}

void LogWriter::close() {
  if (closed_) return;
  flush();
  closed_ = true;
}

}  // namespace vdbmap::io
