#include "vdbmap/io/log_replay.hpp"

#include "vdbmap/io/pose_interpolation.hpp"

#include "vdbmap/timing.hpp"

#include <algorithm>
#include <future>
#include <optional>
#include <stdexcept>

namespace vdbmap {

OnBadFrame parseOnBadFrame(const std::string& text) {
  if (text == "fail") return OnBadFrame::Fail;
  if (text == "skip") return OnBadFrame::Skip;
  throw std::invalid_argument("on-bad-frame must be fail or skip, got '" + text + "'");
}

void ReplayConfig::validate() const {
  if (frame_stride < 1 || frame_stride > 1000000)
    throw std::invalid_argument("ReplayConfig.frame_stride must be in [1, 1e6], got " + std::to_string(frame_stride));
}

namespace {

/// A loaded frame, or the bad-frame error it raised.
struct Loaded {
  std::optional<io::Frame> frame;
  std::optional<io::BadFrameError> error;
  double load_s = 0.0;
};

Loaded loadFrame(const io::FrameSource& source, std::size_t i) {
  Loaded out;
  const Stopwatch load;
  try {
    out.frame = source.load(i);
  } catch (const io::BadFrameError& e) {
    out.error = e;
  }
  out.load_s = load.s();
  return out;
}
}  // namespace

ReplayResult replayLog(const io::FrameSource& source, Mapper& mapper, const ReplayConfig& options) {
  options.validate();
  const Stopwatch wall;
  ReplayResult result;
  std::vector<std::size_t> indices;
  for (std::size_t i = 0; i < source.size(); i += std::size_t(options.frame_stride)) indices.push_back(i);
  result.frames_total = indices.size();

  // Corrections by the frame after which they apply.
  std::multimap<std::size_t, const io::CorrectionEvent*> events;
  if (options.apply_corrections)
    for (const io::CorrectionEvent& e : source.corrections()) events.emplace(e.event_frame, &e);
  std::vector<bool> integrated(source.size(), false);

  Stopwatch cycle;
  std::vector<double> frame_ms;
  frame_ms.reserve(indices.size());
  Vec3d robot_W = Vec3d::Zero();

  // Load the next frame while this one integrates (load_ahead).
  std::future<Loaded> next;
  if (options.load_ahead && !indices.empty())
    next = std::async(std::launch::async, loadFrame, std::cref(source), indices[0]);
  for (std::size_t k = 0; k < indices.size(); ++k) {
    Loaded loaded = options.load_ahead ? next.get() : loadFrame(source, indices[k]);
    if (options.load_ahead && k + 1 < indices.size())
      next = std::async(std::launch::async, loadFrame, std::cref(source), indices[k + 1]);
    result.load_s += loaded.load_s;
    const std::size_t i = indices[k];
    if (loaded.error) {
      if (options.on_bad_frame == OnBadFrame::Fail) throw *loaded.error;
      result.bad_frames.push_back({i, loaded.error->what()});
      ++result.frames_skipped;
    } else {
      const io::Frame& f = *loaded.frame;
      cycle.restart();
      const Stopwatch integration;
      const IntegrationStats stats = mapper.addFrame(i, f.timestamp_s, f.data, f.T_W_S);
      const double ms = integration.ms();
      frame_ms.push_back(ms);
      result.integrate_s += ms / 1e3;
      result.points_invalid += stats.points_invalid;
      ++result.frames_integrated;
      integrated[i] = true;
      robot_W = f.T_W_S.translation();
    }
    // Corrections that apply once frame i (or, with a stride, a frame up to i) is integrated.
    const std::size_t upto = k + 1 < indices.size() ? indices[k + 1] : source.size();
    for (auto it = events.lower_bound(i); it != events.end() && it->first < upto; ++it) {
      // Every integrated frame moves: its correction interpolated between the listed stamps,
      // against the odometry of every usable frame up to the event.
      const io::CorrectionEvent& e = *it->second;
      std::vector<io::StampedPose> odometry;
      std::vector<std::size_t> frame_of;
      for (std::size_t j = 0; j <= e.event_frame; ++j) {
        const io::FrameRecord& r = source.record(j);
        if (!r.problem.empty()) continue;
        odometry.push_back({r.timestamp_s, r.T_W_S});
        frame_of.push_back(j);
      }
      const std::vector<Pose3d> corrected = io::applyCorrection(odometry, e.poses);
      std::map<FrameId, Pose3d> poses;
      for (std::size_t k = 0; k < corrected.size(); ++k)
        if (integrated[frame_of[k]]) poses[frame_of[k]] = corrected[k];
      mapper.updatePoses(poses);
      ++result.correction_events;
    }
    const CycleReport background = mapper.reintegrate(robot_W);
    if (!loaded.error) result.cycle_ms.push_back(cycle.ms());
    result.background_frames += background.frames + background.frames_deintegrated;
    if (options.progress) options.progress(k + 1, indices.size());
  }
  result.background_frames += mapper.reintegrateAll(robot_W);
  result.pruned_frames_deintegrated = mapper.stats().frames_dropped;

  if (!frame_ms.empty()) {
    result.ms_per_frame_median = percentile(frame_ms, 0.5);
    result.integrate_ms_max = *std::max_element(frame_ms.begin(), frame_ms.end());
    result.cycle_ms_median = percentile(result.cycle_ms, 0.5);
    result.ms_per_frame_p99 = percentile(result.cycle_ms, 0.99);
    result.ms_per_frame_max = *std::max_element(result.cycle_ms.begin(), result.cycle_ms.end());
  }
  result.wall_s = wall.s();
  return result;
}

}  // namespace vdbmap
