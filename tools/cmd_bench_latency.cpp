// `vdbmap bench latency LOG -o OUTDIR`: replays a log (ideally one with a loop correction, e.g.
// from `vdbmap drift-log`) in every consistency mode and reports the whole cycle per frame
// (integration, corrections and the background cycle after it): p50 / p90 / p99 / max per mode,
// repeated to see the machine's noise. A peer's numbers (bench/open3d_7scenes.py --json) can be
// put beside them with --peer.
#include "cli_util.hpp"
#include "command.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/log_replay.hpp"
#include "vdbmap/timing.hpp"

#include <cstdio>
#include <fstream>
#include <sstream>

namespace vdbmap::cli {
namespace {

struct BenchLatencyOptions {
  std::filesystem::path log, output, peer;
  std::vector<std::string> modes = {"none", "submap", "all", "keyframes"};
  double voxel_size_m = 0.05;
  double budget_ms = ReintegrationConfig{}.budget_ms;
  int budget_frames = ReintegrationConfig{}.budget_frames;
  int repeat = 1;
  std::string load_ahead = "on";
};

nlohmann::json percentiles(const std::vector<double>& ms) {
  return {{"p50", percentile(ms, 0.5)}, {"p90", percentile(ms, 0.9)}, {"p99", percentile(ms, 0.99)},
          {"max", percentile(ms, 1.0)}};
}

void runBenchLatency(const BenchLatencyOptions& o) {
  const auto source = io::openDataset(o.log);
  std::filesystem::create_directories(o.output);
  nlohmann::json runs = nlohmann::json::array();
  std::ostringstream md;
  md << "| mode | run | cycle p50 ms | p90 | p99 | max | integration p50 ms | total s | kept | background frames |\n"
     << "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  char line[512];
  for (int run = 1; run <= o.repeat; ++run) {
    for (const std::string& mode : o.modes) {
      MapperConfig config;
      config.mode = parseConsistencyMode(mode);
      config.tsdf.voxel_size_m = o.voxel_size_m;
      config.integrator.min_range_m = source->sensor().min_range_m;
      config.integrator.max_range_m = source->sensor().max_range_m;
      config.reintegration.budget_ms = o.budget_ms;
      config.reintegration.budget_frames = o.budget_frames;
      Mapper mapper(config);
      ReplayConfig replay;
      replay.load_ahead = o.load_ahead == "on";
      const ReplayResult r = replayLog(*source, mapper, replay);
      const nlohmann::json p = percentiles(r.cycle_ms);
      double total_s = 0.0;
      for (const double ms : r.cycle_ms) total_s += ms / 1e3;
      runs.push_back({{"mode", mode},
                      {"run", run},
                      {"frames", r.frames_integrated},
                      {"correction_events", r.correction_events},
                      {"cycle_ms", p},
                      {"integration_ms_median", r.ms_per_frame_median},
                      {"cycles_total_s", total_s},
                      {"keyframes_kept", mapper.keyframesKept()},
                      {"background_frames", r.background_frames},
                      {"pruned_frames_deintegrated", r.pruned_frames_deintegrated},
                      {"cycle_ms_per_frame", r.cycle_ms}});
      std::snprintf(line, sizeof(line), "| %s | %d | %.1f | %.1f | %.1f | %.1f | %.1f | %.2f | %zu | %zu |\n",
                    mode.c_str(), run, p["p50"].get<double>(), p["p90"].get<double>(), p["p99"].get<double>(),
                    p["max"].get<double>(), r.ms_per_frame_median, total_s, mapper.keyframesKept(),
                    r.background_frames);
      md << line;
      std::fprintf(stderr, "%s", line);
    }
  }
  nlohmann::json out = {{"log", o.log.string()},
                        {"format", source->format()},
                        {"voxel_size_m", o.voxel_size_m},
                        {"cycle_budget_ms", o.budget_ms},
                        {"cycle_budget_frames", o.budget_frames},
                        {"load_ahead", o.load_ahead == "on"},
                        {"runs", runs}};
  if (!o.peer.empty()) {
    std::ifstream in(o.peer);
    if (!in) throw std::runtime_error("cannot read --peer " + o.peer.string());
    const nlohmann::json peer = nlohmann::json::parse(in);
    out["peer"] = peer;
    std::snprintf(line, sizeof(line), "| %s (integration only) | | %.1f | %.1f | %.1f | %.1f | | %.2f | | |\n",
                  peer.value("peer", std::string("peer")).c_str(), peer.value("ms_per_frame_median", 0.0),
                  peer.value("ms_per_frame_p90", 0.0), peer.value("ms_per_frame_p99", 0.0),
                  peer.value("ms_per_frame_max", 0.0), peer.value("integrate_s", 0.0));
    md << line;
  }
  writeJson(o.output / "latency.json", out);
  const std::string table = md.str();
  vdbmap::writeFileAtomically(o.output / "latency.md", [&](std::ostream& f) { f << table; });
  std::printf("%s", table.c_str());
}

const GroupRegistration registration("bench", "latency", [](CLI::App& bench) {
  auto o = std::make_shared<BenchLatencyOptions>();
  CLI::App* sub = bench.add_subcommand(
      "latency",
      "Whole-cycle time per frame (integration + corrections + background work) of a log replayed in each "
      "consistency mode; writes OUTDIR/latency.json (every cycle) and OUTDIR/latency.md (p50/p90/p99/max)");
  sub->option_defaults()->always_capture_default();
  sub->add_option("log", o->log, "Log or dataset folder (e.g. made by `vdbmap drift-log`)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--modes", o->modes, "Consistency modes (comma-separated)")
      ->delimiter(',')
      ->check(CLI::IsMember({"none", "submap", "all", "keyframes"}));
  sub->add_option("--voxel-size", o->voxel_size_m, "Voxel edge in metres")->check(CLI::Range(1e-3, 10.0));
  sub->add_option("--cycle-budget-ms", o->budget_ms,
                  "Time budget of each frame's cycle (its integration and the background work after it)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--cycle-budget-frames", o->budget_frames, "Background frames per cycle (0 = no limit)")
      ->check(CLI::Range(0, 1000000));
  sub->add_option("--repeat", o->repeat, "Runs of every mode (the machine's noise shows between them)")
      ->check(CLI::Range(1, 100));
  sub->add_option("--load-ahead", o->load_ahead,
                  "on: load the next frame while a cycle runs (as `vdbmap integrate`); off: load each frame before "
                  "its cycle starts, as bench/open3d_7scenes.py times its peer")
      ->check(CLI::IsMember({"on", "off"}));
  sub->add_option("--peer", o->peer, "A peer's JSON line (bench/open3d_7scenes.py) to put beside ours")
      ->check(CLI::ExistingFile);
  sub->add_option("-o,--output", o->output, "Output folder")->required();
  sub->callback([o] { runBenchLatency(*o); });
});

}  // namespace
}  // namespace vdbmap::cli
