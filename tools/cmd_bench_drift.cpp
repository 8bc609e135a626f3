// `vdbmap bench drift --world W.ply -o OUTDIR`: the paper's Table II (map accuracy of each
// consistency mode under the drift levels of Table I); the work is in sim/drift_benchmark.hpp.
#include "command.hpp"

#include "vdbmap/sim/drift_benchmark.hpp"
#include "vdbmap/sim/exploration.hpp"

#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>

namespace vdbmap::cli {
namespace {

struct BenchDriftOptions {
  std::filesystem::path world, trajectory, output;
  std::vector<std::string> levels = driftLevels();
  std::vector<std::string> modes = {"none", "submap", "all", "keyframes"};
  std::uint64_t seed = 1;
  double voxel_size_m = 0.1;
  std::string loop_closure = sim::toString(sim::DriftBenchmarkConfig{}.loop_closure);
  double ceiling_clip_m = std::numeric_limits<double>::infinity();
  bool no_meshes = false;
  std::string budgets = sim::toString(sim::BudgetMode::WallClock);
};

void runBenchDrift(const BenchDriftOptions& o) {
  sim::DriftBenchmarkConfig c;
  c.world_mesh = requireWorld(o.world);
  c.world.ceiling_clip_z_m = o.ceiling_clip_m;
  c.levels = o.levels;
  c.modes.clear();
  for (const std::string& m : o.modes) c.modes.push_back(parseConsistencyMode(m));
  c.seed = o.seed;
  c.voxel_size_m = o.voxel_size_m;
  c.trajectory_file = o.trajectory;
  c.loop_closure = sim::parseLoopClosureMode(o.loop_closure);
  c.write_meshes = !o.no_meshes;
  sim::setReintegrationBudget(c.mapper.reintegration, sim::parseBudgetMode(o.budgets));
  c.report = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  sim::runDriftBenchmark(c, o.output);
  std::ifstream md(o.output / "table.md");
  std::cout << md.rdbuf();
}

const GroupRegistration registration("bench", "drift", [](CLI::App& bench) {
  auto o = std::make_shared<BenchDriftOptions>();
  CLI::App* sub = bench.add_subcommand(
      "drift",
      "Table II: simulate each drift level once, replay it in every consistency mode, evaluate each map "
      "against the world mesh; writes OUTDIR/table.json and OUTDIR/table.md");
  sub->option_defaults()->always_capture_default();
  addWorldOption(*sub, o->world);
  sub->add_option("--levels", o->levels, "Drift levels (comma-separated)")
      ->delimiter(',')
      ->check(CLI::IsMember(driftLevels()));
  sub->add_option("--modes", o->modes, "Consistency modes (comma-separated)")
      ->delimiter(',')
      ->check(CLI::IsMember({"none", "submap", "all", "keyframes"}));
  sub->add_option("--seed", o->seed, "Drift seed, the same for every level");
  sub->add_option("--voxel-size", o->voxel_size_m, "Voxel edge in metres")->check(CLI::PositiveNumber);
  sub->add_option("--trajectory", o->trajectory, "Waypoint file; default: the world's coverage pattern")
      ->check(CLI::ExistingFile);
  sub->add_option("--loop-closure", o->loop_closure,
                  "Correction on loop closure: perfect (ground truth, as the authors' simulator), pgo or off")
      ->check(CLI::IsMember({"pgo", "perfect", "off"}));
  sub->add_option("--ceiling-clip", o->ceiling_clip_m, "Cut the world's mesh at this height (metres)");
  sub->add_flag("--no-meshes", o->no_meshes, "Do not write the meshes of the maps");
  sub->add_option("--budgets", o->budgets,
                  "Re-integration cycles: wall-clock (20 ms, as on a robot; keyframes rows vary a little from run "
                  "to run) or counted (4 frames a cycle: the same table on every run)")
      ->check(CLI::IsMember({"wall-clock", "counted"}));
  sub->add_option("-o,--output", o->output, "Output folder")->required();
  sub->callback([o] { runBenchDrift(*o); });
});

}  // namespace
}  // namespace vdbmap::cli
