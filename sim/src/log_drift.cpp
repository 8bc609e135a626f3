#include "vdbmap/sim/log_drift.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/io/sensor_info.hpp"
#include "vdbmap/io/tum_trajectory.hpp"

#include <cmath>
#include <iomanip>
#include <random>
#include <sstream>
#include <stdexcept>

namespace vdbmap::sim {

void LogDriftConfig::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("LogDriftConfig." + what); };
  if (!(sigma_translation_m >= 0 && sigma_translation_m <= 1)) fail("sigma_translation_m must be in [0, 1]");
  if (!(sigma_yaw_deg >= 0 && sigma_yaw_deg <= 10)) fail("sigma_yaw_deg must be in [0, 10]");
  if (!(min_loop_fraction >= 0 && min_loop_fraction < 1)) fail("min_loop_fraction must be in [0, 1)");
}

DriftedLog writeDriftedLog(const io::FrameSource& source, const std::filesystem::path& out, const LogDriftConfig& config) {
  config.validate();
  if (source.sensor().kind != io::SensorKind::Depth)
    throw std::invalid_argument("writeDriftedLog: " + source.root().string() + " is not a depth dataset");
  const std::size_t n = source.size();
  if (n < 3) throw std::invalid_argument("writeDriftedLog: need at least 3 frames, " + source.root().string() + " has " + std::to_string(n));

  // Gravity: the mean image-down axis; yaw turns about it through the first camera position.
  Vec3d down = Vec3d::Zero();
  for (const io::FrameRecord& r : source.records()) down += r.T_W_S.linear().col(1);
  const Vec3d up = -down.normalized();
  const Vec3d pivot = source.record(0).T_W_S.translation();

  // Loop event: the frame nearest to the start after min_loop_fraction of the sequence.
  DriftedLog info;
  info.frames = n;
  info.event_frame = n - 1;
  info.loop_distance_m = std::numeric_limits<double>::infinity();
  for (std::size_t i = std::size_t(config.min_loop_fraction * double(n)); i < n; ++i) {
    const double d = (source.record(i).T_W_S.translation() - pivot).norm();
    if (d < info.loop_distance_m) {
      info.loop_distance_m = d;
      info.event_frame = i;
    }
  }

  std::mt19937 rng(config.seed);
  std::normal_distribution<double> step_t(0.0, config.sigma_translation_m);
  std::normal_distribution<double> step_yaw(0.0, config.sigma_yaw_deg * M_PI / 180.0);
  double yaw = 0.0;
  Vec3d t = Vec3d::Zero();
  Pose3d anchor = Pose3d::Identity();  // the drift at the event, removed afterwards
  std::vector<Pose3d> odom(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (i > 0) {
      yaw += step_yaw(rng);
      t += Vec3d(step_t(rng), step_t(rng), step_t(rng));
    }
    Pose3d D = Pose3d::Identity();
    D.linear() = Eigen::AngleAxisd(yaw, up).toRotationMatrix();
    D.translation() = pivot - D.linear() * pivot + t;
    odom[i] = anchor * D * source.record(i).T_W_S;
    if (i == info.event_frame) {
      info.drift_at_event_m = (odom[i].translation() - source.record(i).T_W_S.translation()).norm();
      info.drift_at_event_deg = std::abs(yaw) * 180.0 / M_PI;
      anchor = D.inverse();
    }
  }

  std::filesystem::create_directories(out / "corrections");
  io::writeSensorJson(out / "sensor.json", source.sensor());
  vdbmap::writeFileAtomically(out / "frames.csv", [&](std::ostream& os) {
    os << "timestamp,file,tx,ty,tz,qx,qy,qz,qw\n" << std::setprecision(10);
    for (std::size_t i = 0; i < n; ++i) {
      const io::FrameRecord& r = source.record(i);
      const Eigen::Quaterniond q(odom[i].linear());
      const Vec3d p = odom[i].translation();
      os << io::formatTimestamp(r.timestamp_s) << "," << std::filesystem::absolute(r.file).string() << "," << p.x() << ","
         << p.y() << "," << p.z() << "," << q.x() << "," << q.y() << "," << q.z() << "," << q.w() << "\n";
    }
  });
  std::vector<io::StampedPose> truth, corrected;
  for (std::size_t i = 0; i < n; ++i) {
    truth.push_back({source.record(i).timestamp_s, source.record(i).T_W_S});
    if (i <= info.event_frame) corrected.push_back(truth.back());
  }
  io::writeTumTrajectory(out / "groundtruth.txt", truth);
  io::writeTumTrajectory(out / "corrections" / (io::formatTimestamp(source.record(info.event_frame).timestamp_s) + ".txt"),
                         corrected);
  return info;
}

}  // namespace vdbmap::sim
