// `vdbmap integrate LOG -o MAP.vdb`: replays a log or dataset through the mapper.
#include "cli_util.hpp"
#include "command.hpp"

#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/io/log_replay.hpp"
#include "vdbmap/io/ros_bag.hpp"
#include "vdbmap/mesh.hpp"

#include <cstdio>
#include <filesystem>
#include <stdexcept>

namespace vdbmap::cli {
namespace {

struct IntegrateOptions {
  std::filesystem::path log;
  std::filesystem::path output;
  std::filesystem::path mesh;
  std::filesystem::path json;
  std::string format = "auto";
  std::string mode = toString(MapperConfig{}.mode);
  std::string weighting = toString(TsdfConfig{}.weighting);
  std::string integrator = toString(IntegratorConfig{}.ray_mode);
  std::string on_bad_frame = "fail";
  std::string load_ahead = "on";
  double voxel_size_m = TsdfConfig{}.voxel_size_m;
  double truncation_vox = TsdfConfig{}.truncation_vox;
  double max_range_m = 0.0;  // 0 = the sensor's
  int stride = 1;
  int threads = 0;
  int n_ob = SetCoverConfig{}.n_ob;
  double tau_gain = SetCoverConfig{}.tau_gain;
  double budget_ms = ReintegrationConfig{}.budget_ms;
  int budget_frames = ReintegrationConfig{}.budget_frames;
  int submap_frames = MapperConfig{}.submap_frames;
  io::RosBagConfig bag;          // a .bag LOG
  std::vector<double> extrinsic;  // T_body_camera: x y z qx qy qz qw
};

/// Outputs are checked before any work: each one's folder must exist, none may be a folder.
void checkOutput(const std::filesystem::path& path, const char* what) {
  if (path.empty()) return;
  const std::filesystem::path folder = path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
  if (!std::filesystem::is_directory(folder))
    throw std::runtime_error(std::string(what) + " " + path.string() + ": folder " + folder.string() + " does not exist");
  if (std::filesystem::is_directory(path))
    throw std::runtime_error(std::string(what) + " " + path.string() + " is a folder (give a file name)");
}

void runIntegrate(IntegrateOptions o) {
  // `-o map` means map.vdb, so that its companions (map.exact.vdb) are never another map's.
  if (o.output.extension() != ".vdb") o.output += ".vdb";
  if (TsdfVolume::isExactStatePath(o.output))
    throw std::runtime_error("map " + o.output.string() + ": a name ending in .exact.vdb is the name of a map's exact "
                             "companion; choose another");
  checkOutput(o.output, "map");
  checkOutput(o.mesh, "--mesh");
  checkOutput(o.json, "--json");
  if (!o.extrinsic.empty())
    o.bag.T_B_S = poseFromTranslationQuaternion(Vec3d(o.extrinsic[0], o.extrinsic[1], o.extrinsic[2]), o.extrinsic[3],
                                                o.extrinsic[4], o.extrinsic[5], o.extrinsic[6]);
  const bool bag = o.log.extension() == ".bag";
  if (bag && o.max_range_m > 0) o.bag.max_range_m = o.max_range_m;
  const auto source = bag ? io::openRosBag(o.log, o.bag) : io::openDataset(o.log, io::parseDatasetFormat(o.format));
  if (bag) std::fprintf(stderr, "%s\n", source->description().c_str());
  MapperConfig config;
  config.mode = parseConsistencyMode(o.mode);
  config.tsdf.voxel_size_m = o.voxel_size_m;
  config.tsdf.truncation_vox = o.truncation_vox;
  config.tsdf.weighting = parseWeighting(o.weighting);
  config.integrator.min_range_m = source->sensor().min_range_m;
  config.integrator.max_range_m = o.max_range_m > 0 ? o.max_range_m : source->sensor().max_range_m;
  config.integrator.threads = o.threads;
  config.integrator.ray_mode = parseRayMode(o.integrator);
  config.set_cover.n_ob = o.n_ob;
  config.set_cover.tau_gain = o.tau_gain;
  config.reintegration.budget_ms = o.budget_ms;
  config.reintegration.budget_frames = o.budget_frames;
  config.submap_frames = o.submap_frames;
  Mapper mapper(config);

  ReplayConfig replay;
  replay.frame_stride = o.stride;
  replay.on_bad_frame = parseOnBadFrame(o.on_bad_frame);
  replay.load_ahead = o.load_ahead == "on";
  Progress progress("integrate");
  replay.progress = [&](std::size_t done, std::size_t total) { progress.update(done, total); };
  std::fprintf(stderr, "%s: %zu frames (%s)\n", o.log.c_str(), source->size(), source->format().c_str());
  const ReplayResult r = replayLog(*source, mapper, replay);
  progress.finish();
  if (r.frames_integrated == 0)  // an empty map must not replace a good one
    throw std::runtime_error(o.log.string() + ": no frame was integrated (" + std::to_string(r.frames_total) +
                             " listed, " + std::to_string(r.frames_skipped) + " skipped); nothing written");

  const TsdfVolume& volume = mapper.volume();
  mapper.save(o.output);  // and, in all and keyframes modes, MAP.keyframes (for `vdbmap reintegrate`)
  std::size_t triangles = 0;
  if (!o.mesh.empty()) {
    const TriangleMesh mesh = extractMesh(volume);
    triangles = mesh.triangles.size();
    io::writePlyMesh(o.mesh, mesh);
  }
  const MapperStats& s = mapper.stats();
  nlohmann::json bad = nlohmann::json::array();
  for (const BadFrame& b : r.bad_frames) bad.push_back({{"frame", b.index}, {"error", b.message}});
  const nlohmann::json summary = {
      {"log", o.log.string()},
      {"format", source->format()},
      {"mode", toString(config.mode)},
      {"voxel_size_m", config.tsdf.voxel_size_m},
      {"frames_total", r.frames_total},
      {"frames_integrated", r.frames_integrated},
      {"frames_skipped", r.frames_skipped},
      {"bad_frames", bad},
      {"integrate_s", r.integrate_s},
      {"ms_per_frame_median", r.ms_per_frame_median},
      {"integrate_ms_max", r.integrate_ms_max},
      {"cycle_ms_median", r.cycle_ms_median},
      {"ms_per_frame_p99", r.ms_per_frame_p99},
      {"ms_per_frame_max", r.ms_per_frame_max},
      {"cycle_ms", r.cycle_ms},
      {"background_frames", r.background_frames},
      {"pruned_frames_deintegrated", r.pruned_frames_deintegrated},
      {"load_s", r.load_s},
      {"load_ahead", replay.load_ahead},
      {"wall_s", r.wall_s},
      {"correction_events", r.correction_events},
      {"keyframes_kept", mapper.keyframesKept()},
      {"frames_dropped", s.frames_dropped},
      {"reintegrated_frames", s.reintegrated_frames},
      {"reintegration_ms_total", s.reintegration_ms_total},
      {"reintegration_ms_max_cycle", s.reintegration_ms_max_cycle},
      {"keyframe_store_bytes", mapper.keyframeStoreBytes()},
      {"active_voxels", volume.activeVoxelCount()},
      {"map_bytes", volume.memoryBytes()},
      {"mesh_triangles", triangles},
      {"map", o.output.string()},
      {"keyframes_file", config.mode == ConsistencyMode::All || config.mode == ConsistencyMode::Keyframes
                             ? Mapper::keyframesPath(o.output).string()
                             : std::string()},
  };
  if (!o.json.empty()) writeJson(o.json, summary);
  std::printf("integrated %zu of %zu frames (%zu skipped) in %.2f s: %.1f ms/frame median (integration only); "
              "whole cycle %.1f ms median, %.1f ms p99, %.1f ms max\n",
              r.frames_integrated, r.frames_total, r.frames_skipped, r.integrate_s, r.ms_per_frame_median,
              r.cycle_ms_median, r.ms_per_frame_p99, r.ms_per_frame_max);
  std::printf("mode %s: %zu keyframes kept, %zu re-integrations and %zu dropped frames de-integrated in background "
              "cycles (%.0f ms, max cycle %.1f ms), %zu correction events\n",
              toString(config.mode), mapper.keyframesKept(), s.reintegrated_frames, s.frames_dropped,
              s.reintegration_ms_total, s.reintegration_ms_max_cycle, r.correction_events);
  const bool store = config.mode == ConsistencyMode::All || config.mode == ConsistencyMode::Keyframes;
  std::printf("wrote %s%s%s%s%s\n", o.output.c_str(), store ? ", " : "", store ? Mapper::keyframesPath(o.output).c_str() : "",
              o.mesh.empty() ? "" : " and ", o.mesh.c_str());
}

const Registration registration("integrate", [](CLI::App& app) {
  auto o = std::make_shared<IntegrateOptions>();
  CLI::App* sub = app.add_subcommand("integrate", "Integrate a log or dataset folder into a TSDF map (.vdb)");
  sub->option_defaults()->always_capture_default();
  sub->add_option("log", o->log, "Log folder (sensor.json + frames.csv), a dataset folder (7-Scenes, ICL-NUIM, "
                                 "Redwood/TUM, Replica, 3DMatch) or a ROS bag (.bag)")->required()->check(CLI::ExistingPath);
  sub->add_option("--depth-topic", o->bag.depth_topic,
                  "Bag: sensor_msgs/Image depth topic, 16UC1 (mm) or 32FC1 (m) (default: the only Image topic)");
  sub->add_option("--camera-info-topic", o->bag.camera_info_topic, "Bag: sensor_msgs/CameraInfo topic (default: the only one)");
  sub->add_option("--pose-topic", o->bag.pose_topic,
                  "Bag: body poses, nav_msgs/Odometry, geometry_msgs/PoseStamped or TransformStamped, interpolated at "
                  "the depth stamps (default: the only such topic)");
  sub->add_option("--corrections-topic", o->bag.corrections_topic,
                  "Bag: nav_msgs/Path loop corrections, each message an event correcting a subset of stamps "
                  "(default: the only Path topic, if any; '-' for none)");
  sub->add_option("--extrinsic", o->extrinsic, "Bag: T_body_camera as x,y,z,qx,qy,qz,qw (camera = body x extrinsic)")
      ->delimiter(',')
      ->expected(7);
  sub->add_option("-o,--output", o->output,
                  "Map to write (.vdb, appended when missing; the exact state goes beside it as .exact.vdb and, in all "
                  "and keyframes modes, the keyframe store as .keyframes, for `vdbmap reintegrate`)")
      ->required();
  sub->add_option("--format", o->format, "Layout of LOG: auto, log, 7scenes, 3dmatch, iclnuim, redwood, tum, replica");
  sub->add_option("--mode", o->mode, "Consistency under corrections: none, submap, all, keyframes")
      ->check(CLI::IsMember({"none", "submap", "all", "keyframes"}));
  sub->add_option("--voxel-size", o->voxel_size_m, "Voxel edge in metres")->check(CLI::PositiveNumber);
  sub->add_option("--truncation-vox", o->truncation_vox, "Truncation distance in voxels")->check(CLI::Range(1.0, 100.0));
  sub->add_option("--weighting", o->weighting, "Ray weight: constant or inverse_square")
      ->check(CLI::IsMember({"constant", "inverse_square"}));
  sub->add_option("--integrator", o->integrator,
                  "projective: depth images voxel by voxel (fast); merged: rays bundled per end voxel; per_ray: "
                  "one ray per point (reference). Point clouds always use rays")
      ->check(CLI::IsMember({"projective", "merged", "per_ray"}));
  sub->add_option("--max-range", o->max_range_m,
                  "Max range in metres (0 = the sensor's max_range_m); the map's fixed-point weight scale follows it")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--stride", o->stride, "Integrate every k-th frame")->check(CLI::Range(1, 1000000));
  sub->add_option("--threads", o->threads, "Worker threads (0 = all cores)")->check(CLI::Range(0, 1024));
  sub->add_option("--n-ob", o->n_ob, "keyframes: how many kept frames should see each cell")->check(CLI::Range(1, 1000));
  sub->add_option("--tau-gain", o->tau_gain, "keyframes: stop selecting when the best gain (cells) is at most this")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--cycle-budget-ms", o->budget_ms,
                  "Time budget of each frame's cycle: its integration and the background work after it "
                  "(re-integrating moved frames, de-integrating the frames set cover dropped); at least one "
                  "background frame per cycle")
      ->check(CLI::PositiveNumber);
  sub->add_option("--cycle-budget-frames", o->budget_frames,
                  "Also stop a cycle's background work after this many frames (0 = no limit; with a "
                  "--cycle-budget-ms the cycles never reach, e.g. 1e6, runs repeat exactly)")
      ->check(CLI::Range(0, 1000000));
  sub->add_option("--submap-frames", o->submap_frames, "submap: frames per rigid submap")->check(CLI::Range(1, 1000000));
  sub->add_option("--on-bad-frame", o->on_bad_frame, "A corrupt or missing frame: fail the run, or skip and list it")
      ->check(CLI::IsMember({"fail", "skip"}));
  sub->add_option("--load-ahead", o->load_ahead,
                  "on: decode the next frame while a frame integrates (a shorter run; the decoding shares the cores "
                  "with the timed integration); off: decode each frame before its integration starts, as "
                  "bench/open3d_7scenes.py times Open3D")
      ->check(CLI::IsMember({"on", "off"}));
  sub->add_option("--mesh", o->mesh, "Also write the surface mesh (.ply)");
  sub->add_option("--json", o->json, "Write a JSON summary");
  sub->callback([o] { runIntegrate(*o); });
});

}  // namespace
}  // namespace vdbmap::cli
