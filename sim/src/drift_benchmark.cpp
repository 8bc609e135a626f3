#include "vdbmap/sim/drift_benchmark.hpp"
#include "vdbmap/timing.hpp"

#include "text_format.hpp"

#include "vdbmap/eval.hpp"
#include "vdbmap/atomic_file.hpp"
#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/io/log_replay.hpp"
#include "vdbmap/mesh.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <future>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>

namespace vdbmap::sim {

void DriftBenchmarkConfig::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("DriftBenchmarkConfig." + what); };
  if (world_mesh.empty()) fail("world_mesh must name a mesh file");
  world.validate();
  if (levels.empty()) fail("levels must not be empty");
  for (const std::string& level : levels) DriftConfig::preset(level);  // throws for an unknown level
  if (modes.empty()) fail("modes must not be empty");
  if (!(voxel_size_m > 0.0 && voxel_size_m <= 10.0)) fail("voxel_size_m must be in (0, 10]");
  if (!(completeness_threshold_vox > 0.0 && completeness_threshold_vox <= 100.0))
    fail("completeness_threshold_vox must be in (0, 100]");
  coverage.validate();
  limits.validate();
  simulator.validate();
}

namespace {

/// A short name of each mode as the paper's baselines.
const char* paperName(ConsistencyMode m) {
  switch (m) {
    case ConsistencyMode::None:
      return "Voxblox";
    case ConsistencyMode::Submap:
      return "C-blox";
    case ConsistencyMode::All:
      return "Ours w/o pruning";
    case ConsistencyMode::Keyframes:
      return "Ours";
  }
  return "?";
}

DriftBenchmarkRow replayMode(const io::FrameSource& log, ConsistencyMode mode, const DriftBenchmarkConfig& c,
                             const TriangleMesh& ground_truth, const std::filesystem::path& mesh_out) {
  const Stopwatch replay_watch;
  MapperConfig mc = c.mapper;
  mc.mode = mode;
  mc.tsdf.voxel_size_m = c.voxel_size_m;
  mc.integrator.min_range_m = log.sensor().min_range_m;
  mc.integrator.max_range_m = log.sensor().max_range_m;
  Mapper mapper(mc);
  const ReplayResult replay = replayLog(log, mapper, ReplayConfig{});
  DriftBenchmarkRow row;
  row.mode = toString(mode);
  row.frames_total = replay.frames_integrated;
  row.keyframes_kept = mapper.keyframesKept();
  row.reintegrated_frames = mapper.stats().reintegrated_frames;
  row.correction_events = replay.correction_events;
  row.wall_s = replay_watch.s();

  const TriangleMesh mesh = extractMesh(mapper.volume());
  if (mesh.vertices.empty())
    throw std::runtime_error(log.root().string() + ": mode " + row.mode + " produced an empty map");
  if (!mesh_out.empty()) io::writePlyMesh(mesh_out, mesh);
  EvalConfig eval;
  eval.completeness_threshold_m = c.completeness_threshold_vox * c.voxel_size_m;
  eval.sample_spacing_m = 0.5 * c.voxel_size_m;
  const SurfaceEval e = evaluateSurface(mesh, ground_truth, eval);
  row.accuracy_rmse_m = e.accuracy_rmse_m;
  row.accuracy_mean_m = e.accuracy_mean_m;
  row.completeness = e.completeness;
  return row;
}

nlohmann::json toJson(const DriftBenchmarkRow& r) {
  return {{"level", r.level},
          {"mode", r.mode},
          {"accuracy_rmse_m", r.accuracy_rmse_m},
          {"accuracy_mean_m", r.accuracy_mean_m},
          {"completeness", r.completeness},
          {"frames_total", r.frames_total},
          {"keyframes_kept", r.keyframes_kept},
          {"reintegrated_frames", r.reintegrated_frames},
          {"correction_events", r.correction_events},
          {"wall_s", r.wall_s}};
}
}  // namespace

DriftBenchmarkResult runDriftBenchmark(const DriftBenchmarkConfig& config, const std::filesystem::path& out_dir) {
  config.validate();
  const Stopwatch wall;
  std::mutex report_mutex;
  auto report = [&](const std::string& line) {
    const std::lock_guard<std::mutex> lock(report_mutex);
    if (config.report) config.report(line);
  };
  const World world = World::load(config.world_mesh, config.world);
  SampledTrajectory trajectory;
  if (!config.trajectory_file.empty()) {
    trajectory = timeParametrize(readWaypoints(config.trajectory_file), config.limits, config.coverage.dt_s);
  } else {
    trajectory = planCoverage(world, config.coverage).trajectory;
  }
  report("world " + config.world_mesh.string() + ": " + std::to_string(world.stats().triangles) +
         " triangles; flight " + format("%.1f s", trajectory.duration()) + ", " +
         format("%.1f m", trajectory.length_m()));
  std::filesystem::create_directories(out_dir);

  auto simulate = [&](const std::string& level) {
    SimulatorConfig sc = config.simulator;
    sc.drift = DriftConfig::preset(level, config.seed);
    sc.loop_closure = config.loop_closure;
    FlightConfig fo;
    fo.overwrite = true;
    fo.description = "vdbmap bench drift: level " + level + ", world " + config.world_mesh.string();
    const Stopwatch flight_watch;
    const FlightResult flight = simulateFlight(world, trajectory, sc, out_dir / level / "log", fo);
    report(level + ": simulated " + std::to_string(flight.frames) + " frames, " +
           std::to_string(flight.loop_closures.size()) + " loop closures, odometry error at the end " +
           format("%.3f m", flight.odometry_error_final_m) + " (" + format("%.1f s", flight_watch.s()) + ")");
    return flight;
  };
  auto replay = [&](const io::FrameSource& log, const std::string& level, ConsistencyMode mode) {
    const std::filesystem::path mesh_out =
        config.write_meshes ? out_dir / level / (std::string(toString(mode)) + ".ply") : std::filesystem::path();
    DriftBenchmarkRow row = replayMode(log, mode, config, world.mesh(), mesh_out);
    row.level = level;
    report(level + " " + row.mode + ": rmse " + format("%.4f m", row.accuracy_rmse_m) + ", completeness " +
           format("%.3f", row.completeness) + ", " + std::to_string(row.keyframes_kept) + " of " +
           std::to_string(row.frames_total) + " frames kept (" + format("%.1f s", row.wall_s) + ")");
    return row;
  };

  // The modes of a level replay concurrently with each other and with the next level's flight:
  // their serial phases (PNG coding, submap fusion, evaluation) then leave no core idle. Results
  // do not depend on it: a map does not depend on thread count or timing, and re-integration
  // queues are drained before evaluation.
  DriftBenchmarkResult result;
  std::future<FlightResult> next_flight = std::async(std::launch::async, simulate, config.levels.front());
  for (std::size_t l = 0; l < config.levels.size(); ++l) {
    const std::string& level = config.levels[l];
    result.levels.push_back({level, next_flight.get()});
    if (l + 1 < config.levels.size()) next_flight = std::async(std::launch::async, simulate, config.levels[l + 1]);
    const std::unique_ptr<io::FrameSource> log = io::openDataset(out_dir / level / "log", io::DatasetFormat::Log);
    std::vector<std::future<DriftBenchmarkRow>> rows;
    for (const ConsistencyMode mode : config.modes)
      rows.push_back(std::async(std::launch::async, replay, std::cref(*log), level, mode));
    for (auto& row : rows) result.rows.push_back(row.get());
  }
  result.wall_s = wall.s();

  nlohmann::json table = nlohmann::json::array();
  for (const DriftBenchmarkRow& r : result.rows) table.push_back(toJson(r));
  vdbmap::writeFileAtomically(out_dir / "table.json", [&](std::ostream& os) { os << table.dump(2) << "\n"; });
  const std::string md = driftBenchmarkMarkdown(result, config);
  vdbmap::writeFileAtomically(out_dir / "table.md", [&](std::ostream& os) { os << md; });
  return result;
}

std::string driftBenchmarkMarkdown(const DriftBenchmarkResult& result, const DriftBenchmarkConfig& config) {
  std::map<std::pair<std::string, std::string>, const DriftBenchmarkRow*> cell;
  for (const DriftBenchmarkRow& r : result.rows) cell[{r.mode, r.level}] = &r;
  std::ostringstream md;
  auto table = [&](const std::string& title, const std::function<std::string(const DriftBenchmarkRow&)>& value) {
    md << "\n" << title << "\n\n| method | mode |";
    for (const std::string& l : config.levels) md << " " << l << " |";
    md << "\n|---|---|";
    for (std::size_t i = 0; i < config.levels.size(); ++i) md << "---:|";
    md << "\n";
    for (const ConsistencyMode m : config.modes) {
      md << "| " << paperName(m) << " | " << toString(m) << " |";
      for (const std::string& l : config.levels) {
        const auto it = cell.find({toString(m), l});
        md << " " << (it == cell.end() ? std::string("-") : value(*it->second)) << " |";
      }
      md << "\n";
    }
  };
  md << "# Mapping accuracy under odometry drift (Table II layout)\n\n"
     << "World `" << config.world_mesh.string() << "`, voxel " << config.voxel_size_m << " m, seed " << config.seed
     << ", loop closure `" << toString(config.loop_closure) << "`. Accuracy: RMSE of the distance from the "
     << "map's surface (mesh vertices) to the world's mesh. Completeness: fraction of the world's surface within "
     << config.completeness_threshold_vox << " voxels of the map (unobservable surfaces included, so below 1).\n";
  table("## Accuracy RMSE (m)", [](const DriftBenchmarkRow& r) { return format("%.4f", r.accuracy_rmse_m); });
  table("## Completeness", [](const DriftBenchmarkRow& r) { return format("%.3f", r.completeness); });
  table("## Frames kept / integrated", [](const DriftBenchmarkRow& r) {
    return std::to_string(r.keyframes_kept) + " / " + std::to_string(r.frames_total);
  });
  table("## Replay wall time (s; the modes run concurrently)",
        [](const DriftBenchmarkRow& r) { return format("%.1f", r.wall_s); });
  md << "\n## Flights\n\n| level | frames | duration (s) | path (m) | loop closures | odometry error end / max (m) | "
        "estimate error RMSE / max (m) |\n|---|---:|---:|---:|---:|---:|---:|\n";
  for (const DriftBenchmarkLevel& l : result.levels) {
    const FlightResult& f = l.flight;
    md << "| " << l.level << " | " << f.frames << " | " << format("%.1f", f.duration_s) << " | "
       << format("%.1f", f.path_length_m) << " | " << f.loop_closures.size() << " | "
       << format("%.3f", f.odometry_error_final_m) << " / " << format("%.3f", f.odometry_error_max_m) << " | "
       << format("%.3f", f.estimate_error_rmse_m) << " / " << format("%.3f", f.estimate_error_max_m) << " |\n";
  }
  md << "\nTotal wall time " << format("%.0f s", result.wall_s) << ".\n";
  return md.str();
}

}  // namespace vdbmap::sim
