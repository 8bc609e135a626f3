// `vdbmap reintegrate MAP.vdb --trajectory T.txt [--extrinsic x,y,z,qx,qy,qz,qw] -o OUT.vdb`:
// corrects a saved map afterwards with a better trajectory (e.g. a SLAM back end's final one):
// every keyframe's pose is corrected (io::applyCorrection: any subset of stamps, interpolated)
// and only the frames that moved are re-integrated; the result equals integrating the same
// frames from scratch at the corrected poses, bit for bit.
#include "command.hpp"

#include "vdbmap/io/pose_interpolation.hpp"
#include "vdbmap/io/timestamps.hpp"
#include "vdbmap/io/tum_trajectory.hpp"
#include "vdbmap/mapper.hpp"
#include "vdbmap/timing.hpp"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

namespace vdbmap::cli {
namespace {

struct ReintegrateOptions {
  std::filesystem::path map, trajectory, output;
  std::vector<double> extrinsic;  ///< T_body_camera: x y z qx qy qz qw
  bool overwrite = false;
};

void runReintegrate(ReintegrateOptions o) {
  if (o.output.extension() != ".vdb") o.output += ".vdb";
  if (TsdfVolume::isExactStatePath(o.output))
    throw std::runtime_error(o.output.string() + ": a name ending in .exact.vdb is the name of a map's exact "
                             "companion; choose another");
  if (std::filesystem::exists(o.output) && !o.overwrite)
    throw std::runtime_error(o.output.string() + " exists; give --overwrite to replace it");
  if (std::error_code ec; std::filesystem::equivalent(o.map, o.output, ec))
    throw std::runtime_error("-o must differ from the map being corrected (" + o.map.string() + ")");
  const Stopwatch wall;
  Mapper mapper = Mapper::load(o.map);
  Pose3d T_B_S = Pose3d::Identity();
  if (!o.extrinsic.empty())
    T_B_S = poseFromTranslationQuaternion(Vec3d(o.extrinsic[0], o.extrinsic[1], o.extrinsic[2]), o.extrinsic[3],
                                          o.extrinsic[4], o.extrinsic[5], o.extrinsic[6]);

  // The odometry: every keyframe where the map holds it, in time order.
  std::vector<std::pair<io::StampedPose, FrameId>> held;
  for (const auto& [id, kf] : mapper.keyframes()) held.push_back({{kf.timestamp, kf.T_W_S_integrated}, id});
  if (held.empty()) throw std::runtime_error(o.map.string() + ": its keyframe store holds no frame");
  std::sort(held.begin(), held.end(), [](const auto& a, const auto& b) { return a.first.timestamp_s < b.first.timestamp_s; });
  std::vector<io::StampedPose> track;
  std::vector<FrameId> ids;
  for (const auto& [pose, id] : held) {
    if (!track.empty() && !(pose.timestamp_s > track.back().timestamp_s))
      throw std::runtime_error(Mapper::keyframesPath(o.map).string() + ": two keyframes share the stamp " +
                               io::formatTimestamp(pose.timestamp_s));
    track.push_back(pose);
    ids.push_back(id);
  }

  // The corrected camera poses within the keyframes' span (stamps matching a keyframe become its).
  std::vector<io::StampedPose> corrected;
  std::size_t outside = 0;
  for (io::StampedPose p : io::readTumTrajectory(o.trajectory)) {
    if (const auto near = io::findStamp(track.begin(), track.end(), p.timestamp_s); near != track.end())
      p.timestamp_s = near->timestamp_s;
    if (p.timestamp_s < track.front().timestamp_s || p.timestamp_s > track.back().timestamp_s) {
      ++outside;
      continue;
    }
    if (!corrected.empty() && !(p.timestamp_s > corrected.back().timestamp_s)) continue;  // two matched one keyframe
    p.T_W_S = p.T_W_S * T_B_S;
    corrected.push_back(p);
  }
  if (corrected.empty())
    throw std::runtime_error(o.trajectory.string() + ": no pose within the keyframes' time span " +
                             io::formatTimestamp(track.front().timestamp_s) + " to " +
                             io::formatTimestamp(track.back().timestamp_s));
  const std::vector<Pose3d> poses = io::applyCorrection(track, corrected);
  std::map<FrameId, Pose3d> by_id;
  for (std::size_t k = 0; k < poses.size(); ++k) by_id[ids[k]] = poses[k];
  const std::size_t moved = mapper.updatePoses(by_id);
  const std::size_t done = mapper.reintegrateAll(track.back().T_W_S.translation());
  mapper.save(o.output);
  std::printf("%s: %zu keyframes, %zu poses of %s used (%zu outside the keyframes' span), %zu frames moved beyond "
              "the gates and re-integrated (%zu), %.2f s; wrote %s and %s\n",
              o.map.c_str(), track.size(), corrected.size(), o.trajectory.c_str(), outside, moved, done, wall.s(),
              o.output.c_str(), Mapper::keyframesPath(o.output).c_str());
}

const Registration registration("reintegrate", [](CLI::App& app) {
  auto o = std::make_shared<ReintegrateOptions>();
  CLI::App* sub = app.add_subcommand(
      "reintegrate",
      "Correct a saved map afterwards: re-integrate the frames of MAP.keyframes (written by integrate in all or "
      "keyframes mode) at the poses of a better trajectory; the result equals integrating them there from scratch");
  sub->option_defaults()->always_capture_default();
  sub->add_option("map", o->map, "The map (.vdb) with its .exact.vdb and .keyframes beside it")->required()->check(CLI::ExistingFile);
  sub->add_option("--trajectory", o->trajectory,
                  "TUM trajectory of corrected poses (any subset of stamps: each keyframe's correction is "
                  "interpolated between them, docs/formats.md)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--extrinsic", o->extrinsic,
                  "T_body_camera as x,y,z,qx,qy,qz,qw when the trajectory holds body poses (camera = body x extrinsic)")
      ->delimiter(',')
      ->expected(7);
  sub->add_flag("--overwrite", o->overwrite, "Replace OUT if it exists");
  sub->add_option("-o,--output", o->output, "The corrected map (.vdb; its .exact.vdb and .keyframes beside it)")->required();
  sub->callback([o] { runReintegrate(*o); });
});

}  // namespace
}  // namespace vdbmap::cli
