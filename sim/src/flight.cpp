#include "vdbmap/sim/flight.hpp"

#include "vdbmap/io/atomic_file.hpp"
#include "vdbmap/io/log_writer.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

namespace vdbmap::sim {
namespace {
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

FlatPose flatPose(const FlatState& s) { return {s.p_W, s.yaw}; }

nlohmann::json describe(const SimulatorConfig& c) {
  const CameraIntrinsics& K = c.camera.intrinsics;
  return {{"camera",
           {{"width", K.width},
            {"height", K.height},
            {"fx", K.fx},
            {"fy", K.fy},
            {"cx", K.cx},
            {"cy", K.cy},
            {"rate_hz", c.camera.rate_hz},
            {"min_range_m", c.camera.min_range_m},
            {"max_range_m", c.camera.max_range_m},
            {"far_clip_m", c.camera.far_clip_m},
            {"noise_sigma_m", c.camera.noise_sigma_m},
            {"pitch_rad", c.camera_pitch_rad}}},
          {"drift",
           {{"mu_xyz_mps", c.drift.mu_xyz_mps},
            {"sigma2_xyz_m2ps2", c.drift.sigma2_xyz_m2ps2},
            {"mu_yaw_radps", c.drift.mu_yaw_radps},
            {"sigma2_yaw_rad2ps2", c.drift.sigma2_yaw_rad2ps2},
            {"rate_hz", c.drift.rate_hz},
            {"seed", c.drift.seed},
            {"frame", "body"}}},
          {"loop_closure",
           {{"mode", toString(c.loop_closure)},
            {"max_distance_m", c.loop.max_distance_m},
            {"max_yaw_rad", c.loop.max_yaw_rad},
            {"min_age_s", c.loop.min_age_s},
            {"min_interval_s", c.loop.min_interval_s},
            {"min_view_overlap", c.loop.min_view_overlap},
            {"loop_sigma_m", c.loop_sigma_m},
            {"loop_sigma_yaw_rad", c.loop_sigma_yaw_rad}}}};
}
}  // namespace

FlightResult simulateFlight(const World& world, const Trajectory& trajectory, const SimulatorConfig& config,
                            const std::filesystem::path& log_dir, const FlightOptions& options) {
  config.validate();
  if (trajectory.empty()) throw std::invalid_argument("simulateFlight: empty trajectory");
  const auto wall0 = Clock::now();
  const double t0 = trajectory.startTime(), t_end = trajectory.endTime();
  Simulator sim(world, config, flatPose(trajectory.sample(t0)), t0);
  // The odometry alone (no loop closure), for the drift statistics: same seed, same draws.
  DriftingOdometry raw(config.drift, flatPose(trajectory.sample(t0)), t0);

  io::LogWriterOptions writer_options;
  writer_options.overwrite = options.overwrite;
  io::LogWriter writer(log_dir, sim.camera().sensorInfo(), writer_options);

  const double period = sim.camera().period_s();
  const double dt = 1.0 / config.drift.rate_hz;
  const std::size_t n_frames = std::size_t(std::floor((t_end - t0) / period + 1e-9)) + 1;
  FlightResult result;
  result.frames = n_frames;
  result.duration_s = t_end - t0;
  result.path_length_m = trajectory.length_m();
  std::vector<double> frame_t, capture_ms;
  double sq_error = 0.0;
  std::size_t tick = 0;
  const auto advanceTo = [&](double t) {
    const FlatPose truth = flatPose(trajectory.sample(t));
    sim.advance(t, truth);
    raw.advance(t, truth);
  };
  for (std::size_t k = 0; k < n_frames; ++k) {
    const double t_k = t0 + double(k) * period;
    // Advance at the drift rate up to the frame time, then to the frame time itself.
    while (t0 + double(tick + 1) * dt < t_k - 1e-9 * dt) advanceTo(t0 + double(++tick) * dt);
    if (t_k > sim.time()) advanceTo(t_k);
    const auto r0 = Clock::now();
    const SimFrame frame = sim.capture();
    capture_ms.push_back(msSince(r0));
    writer.addDepthFrame(t_k, frame.depth, frame.T_W_S_estimate);
    writer.addGroundTruth(t_k, frame.T_W_S_true);
    frame_t.push_back(t_k);
    if (frame.correction) {
      std::vector<io::StampedPose> poses;
      poses.reserve(frame.correction->T_W_S_by_frame.size());
      for (const auto& [i, T] : frame.correction->T_W_S_by_frame) poses.push_back({frame_t.at(i), T});
      writer.addCorrection(t_k, poses);
      result.loop_closures.push_back(frame.correction->loop);
    }
    const double odom_error = (raw.pose().p_W - frame.body_true.p_W).norm();
    const double estimate_error = (frame.body_estimate.p_W - frame.body_true.p_W).norm();
    result.odometry_error_max_m = std::max(result.odometry_error_max_m, odom_error);
    result.odometry_error_final_m = odom_error;
    result.estimate_error_max_m = std::max(result.estimate_error_max_m, estimate_error);
    sq_error += estimate_error * estimate_error;
    if (options.progress) options.progress(k + 1, n_frames);
  }
  writer.close();
  result.estimate_error_rmse_m = std::sqrt(sq_error / double(n_frames));
  std::nth_element(capture_ms.begin(), capture_ms.begin() + capture_ms.size() / 2, capture_ms.end());
  result.capture_ms_median = capture_ms[capture_ms.size() / 2];
  result.wall_s = msSince(wall0) / 1e3;

  nlohmann::json loops = nlohmann::json::array();
  for (const LoopClosure& l : result.loop_closures)
    loops.push_back({{"old_frame", l.old_frame},
                     {"new_frame", l.new_frame},
                     {"t_s", frame_t.at(l.new_frame)},
                     {"distance_m", l.distance_m},
                     {"yaw_difference_rad", l.yaw_difference_rad},
                     {"view_overlap", l.view_overlap}});
  nlohmann::json summary = describe(config);
  summary["description"] = options.description;
  summary["frames"] = result.frames;
  summary["duration_s"] = result.duration_s;
  summary["path_length_m"] = result.path_length_m;
  summary["loop_closures"] = loops;
  summary["odometry_error_final_m"] = result.odometry_error_final_m;
  summary["odometry_error_max_m"] = result.odometry_error_max_m;
  summary["estimate_error_rmse_m"] = result.estimate_error_rmse_m;
  summary["estimate_error_max_m"] = result.estimate_error_max_m;
  summary["capture_ms_median"] = result.capture_ms_median;
  summary["wall_s"] = result.wall_s;
  io::writeFileAtomically(log_dir / "simulation.json", [&](std::ostream& os) { os << summary.dump(2) << "\n"; });
  return result;
}

}  // namespace vdbmap::sim
