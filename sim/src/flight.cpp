#include "vdbmap/sim/flight.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/io/log_writer.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace vdbmap::sim {
namespace {

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

void flyAlong(Simulator& sim, const SampledTrajectory& trajectory, double t_end_s,
              const std::function<void(SimFrame&)>& on_frame) {
  if (trajectory.empty()) throw std::invalid_argument("flyAlong: empty trajectory");
  flyAlong(sim, [&](double t) { return trajectory.sample(t).pose(); }, t_end_s, on_frame);
}

void flyAlong(Simulator& sim, const std::function<FlatPose(double)>& truth_at, double t_end_s,
              const std::function<void(SimFrame&)>& on_frame) {
  const double dt = 1.0 / sim.config().drift.rate_hz, t0 = sim.startTime();
  const auto advanceTo = [&](double t) { sim.advance(t, truth_at(t)); };
  for (;;) {
    const double t_frame = sim.nextFrameTime(), t_stop = std::min(t_frame, t_end_s);
    // Drift ticks on the grid t0 + k dt up to the stop, then the stop itself.
    for (double k = std::floor((sim.time() - t0) / dt + 1e-9) + 1.0;; k += 1.0) {
      const double t = t0 + k * dt;
      if (t >= t_stop - 1e-9) break;
      advanceTo(t);
    }
    if (t_stop > sim.time()) advanceTo(t_stop);
    if (t_frame > t_end_s + 1e-9) return;
    SimFrame frame = sim.capture();
    on_frame(frame);
  }
}

// ---- recording ---------------------------------------------------------------------------------

struct FlightRecorder::Log {
  io::LogWriter writer;
  Log(const std::filesystem::path& dir, const io::SensorInfo& sensor, const io::LogWriterConfig& options)
      : writer(dir, sensor, options) {}
};

FlightRecorder::FlightRecorder(const std::filesystem::path& log_dir, const Simulator& sim, bool overwrite) {
  io::LogWriterConfig options;
  options.overwrite = overwrite;
  log_ = std::make_unique<Log>(log_dir, sim.camera().sensorInfo(), options);
}

FlightRecorder::~FlightRecorder() = default;

void FlightRecorder::record(const SimFrame& frame) {
  io::LogWriter& writer = log_->writer;
  writer.addDepthFrame(frame.t_s, frame.depth, frame.T_W_S_estimate);
  writer.addGroundTruth(frame.t_s, frame.T_W_S_true);
  frame_t_.push_back(frame.t_s);
  if (frame.correction) {
    std::vector<io::StampedPose> poses;
    poses.reserve(frame.correction->T_W_S_by_frame.size());
    for (const auto& [i, T] : frame.correction->T_W_S_by_frame) poses.push_back({frame_t_.at(i), T});
    writer.addCorrection(frame.t_s, poses);
    result_.loop_closures.push_back(frame.correction->loop);
  }
  const double odom_error = (frame.body_odometry.position_W - frame.body_true.position_W).norm();
  const double estimate_error = (frame.body_estimate.position_W - frame.body_true.position_W).norm();
  result_.odometry_error_max_m = std::max(result_.odometry_error_max_m, odom_error);
  result_.odometry_error_final_m = odom_error;
  result_.estimate_error_max_m = std::max(result_.estimate_error_max_m, estimate_error);
  sq_error_ += estimate_error * estimate_error;
  frame_ms_.push_back(since_last_frame_.ms());
  since_last_frame_.restart();
}

FlightResult FlightRecorder::finish(const SimulatorConfig& config, const std::string& description, double duration_s,
                                    double path_length_m) {
  log_->writer.close();
  FlightResult result = result_;
  result.frames = frame_t_.size();
  result.duration_s = duration_s;
  result.path_length_m = path_length_m;
  if (result.frames > 0) {
    result.estimate_error_rmse_m = std::sqrt(sq_error_ / double(result.frames));
    std::vector<double> ms = frame_ms_;
    std::nth_element(ms.begin(), ms.begin() + std::ptrdiff_t(ms.size() / 2), ms.end());
    result.frame_ms_median = ms[ms.size() / 2];
  }
  result.wall_s = since_start_.s();

  nlohmann::json loops = nlohmann::json::array();
  for (const LoopClosure& l : result.loop_closures)
    loops.push_back({{"old_frame", l.old_frame},
                     {"new_frame", l.new_frame},
                     {"t_s", frame_t_.at(l.new_frame)},
                     {"distance_m", l.distance_m},
                     {"yaw_difference_rad", l.yaw_difference_rad},
                     {"view_overlap", l.view_overlap}});
  nlohmann::json summary = describe(config);
  summary["description"] = description;
  summary["frames"] = result.frames;
  summary["duration_s"] = result.duration_s;
  summary["path_length_m"] = result.path_length_m;
  summary["loop_closures"] = loops;
  summary["odometry_error_final_m"] = result.odometry_error_final_m;
  summary["odometry_error_max_m"] = result.odometry_error_max_m;
  summary["estimate_error_rmse_m"] = result.estimate_error_rmse_m;
  summary["estimate_error_max_m"] = result.estimate_error_max_m;
  summary["frame_ms_median"] = result.frame_ms_median;
  summary["wall_s"] = result.wall_s;
  vdbmap::writeFileAtomically(log_->writer.folder() / "simulation.json",
                          [&](std::ostream& os) { os << summary.dump(2) << "\n"; });
  return result;
}

FlightResult simulateFlight(const World& world, const SampledTrajectory& trajectory, const SimulatorConfig& config,
                            const std::filesystem::path& log_dir, const FlightConfig& options) {
  config.validate();
  if (trajectory.empty()) throw std::invalid_argument("simulateFlight: empty trajectory");
  const double t0 = trajectory.startTime(), t_end = trajectory.endTime();
  Simulator sim(world, config, trajectory.sample(t0).pose(), t0);
  FlightRecorder recorder(log_dir, sim, options.overwrite);
  const std::size_t n_frames = std::size_t(std::floor((t_end - t0) / sim.camera().period_s() + 1e-9)) + 1;
  flyAlong(sim, trajectory, t_end, [&](SimFrame& frame) {
    recorder.record(frame);
    if (options.progress) options.progress(recorder.frames(), n_frames);
  });
  return recorder.finish(config, options.description, t_end - t0, trajectory.length_m());
}

}  // namespace vdbmap::sim
