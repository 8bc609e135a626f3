// `vdbmap explore [--world W.ply] [--drift s1..s4] [--seed N] [--voxel-size M] [--max-time-s T]
// [--mode keyframes|all|none|submap] [--start x,y,z] [--box ...] [--ceiling Z] [--alc on|off]
// [--epsilon E] [--safety on|off] [--budgets counted|wall-clock] [--report] -o RUNDIR`: explores
// the world with the simulated vehicle, the mapper and the exploration planner in closed loop, and
// writes the run folder (see sim/exploration.hpp).
#include "cli_util.hpp"
#include "command.hpp"

#include "report/report.hpp"
#include "vdbmap/sim/exploration.hpp"
#include "vdbmap/timing.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <limits>

namespace vdbmap::cli {
namespace {

struct ExploreOptions {
  std::filesystem::path world, output;
  std::string drift = "s1";
  std::string mode = toString(MapperConfig{}.mode);
  std::string loop_closure = sim::toString(sim::SimulatorConfig{}.loop_closure);
  std::uint64_t seed = 1;
  double voxel_size_m = TsdfConfig{}.voxel_size_m;
  double max_time_s = sim::ExplorationConfig::kDefaultMaxTime_s;
  double ceiling_m = 2.5;
  double start_yaw = 0.0;
  std::vector<double> start, box;
  std::string alc = "off";
  std::string safety = planner::SafetyConfig{}.enabled ? "on" : "off";
  double safety_window_s = planner::RecentFramesConfig{}.window_s;
  double safety_max_window_s = planner::SafetyConfig{}.max_window_s;
  std::string safety_seen_free = planner::SafetyConfig{}.seen_free_is_free ? "on" : "off";
  std::string safety_map_thin = mapThinName(planner::SafetyConfig{});
  std::string safety_free_clears = planner::RecentFramesConfig{}.newer_free_clears ? "on" : "off";
  double safety_vertical_margin_m = planner::SafetyConfig{}.vertical_margin_m;
  double safety_vertical_sigmas = planner::SafetyConfig{}.vertical_margin_sigmas;
  double safety_vertical_margin_max_m = planner::SafetyConfig{}.max_vertical_margin_m;
  double safety_look_side_m = planner::SafetyConfig{}.look_side_m;
  std::string safety_look_steep = planner::SafetyConfig{}.look_steep ? "on" : "off";
  std::string safety_seen_until_arrival = planner::SafetyConfig{}.seen_until_arrival ? "on" : "off";
  std::string safety_path_drift = planner::toString(planner::SafetyConfig{}.path_drift);
  double safety_near_tolerance_m = planner::SafetyConfig{}.near_drift_tolerance_m;
  std::string budgets = sim::toString(sim::BudgetMode::Counted);
  double epsilon = planner::AlcConfig{}.epsilon;
  double finish_loop_age_s = planner::AlcConfig{}.finish_loop_age_s;
  double w_dir = planner::CostConfig{}.w_dir;
  std::string lead_in = planner::TrajectoryConfig{}.lead_in_at_speed ? "at-speed" : "straight";
  int min_cluster_size = planner::FrontierConfig{}.min_cluster_size;
  int revisit_rounds = planner::ExplorationManagerConfig{}.revisit_rounds;
  int final_min_cluster_size = planner::ExplorationManagerConfig{}.final_min_cluster_size;
  std::string final_sweep = planner::toString(planner::ExplorationManagerConfig{}.final_sweep);
  bool look_into_unknown = planner::ViewpointConfig{}.look_into_unknown;
  std::string vertical_frontier = planner::viewScoreName(planner::ViewpointConfig{}.vertical_into_unknown);
  int fallback_min_visible = planner::ViewpointFallback{}.min_visible_samples;
  int fallback_large_voxels = planner::ViewpointFallback{}.large_cluster_voxels;
  int fallback_large_min_visible = planner::ViewpointFallback{}.large_min_visible_samples;
  int fallback_large_min_visible_late = planner::ExplorationManagerConfig{}.late_large_min_visible_samples;
  bool no_initial_turn = false;
  bool overwrite = false;
  bool report = false;
};

/// A progress line on a terminal (rewritten in place), else a line every 10 s of simulated time.
class ExploreProgress {
 public:
  ExploreProgress() : tty_(::isatty(STDERR_FILENO) != 0) {}
  void update(const sim::ExplorationProgress& p) {
    if (!tty_ && p.t_s < next_line_t_) return;
    next_line_t_ = p.t_s + 10.0;
    std::fprintf(stderr, "%sexplore t %6.1f s  frames %5zu  clusters %3zu  replans %4zu  path %6.1f m  loops %zu  collisions %zu  %s%s",
                 tty_ ? "\r" : "", p.t_s, p.frames, p.clusters, p.replans, p.path_length_m, p.loop_closures,
                 p.collisions, planner::toString(p.status), tty_ ? "   " : "\n");
    std::fflush(stderr);
  }
  void finish() {
    if (tty_) std::fprintf(stderr, "\n");
  }

 private:
  bool tty_;
  double next_line_t_ = 0.0;
};

void runExplore(const ExploreOptions& o) {
  sim::WorldConfig wc;
  if (o.ceiling_m > 0.0) {
    wc.ceiling_clip_z_m = o.ceiling_m;
    wc.cap_ceiling = true;
  }
  const sim::World world = sim::World::load(requireWorld(o.world), wc);

  sim::ExplorationConfig config = sim::explorationConfigFor(world, o.drift, o.seed, o.voxel_size_m);
  config.simulator.loop_closure = sim::parseLoopClosureMode(o.loop_closure);
  config.mapper.mode = parseConsistencyMode(o.mode);
  config.max_time_s = o.max_time_s;
  sim::setBudgets(config, sim::parseBudgetMode(o.budgets));
  config.planner.initial_turn = !o.no_initial_turn;
  config.planner.alc_enabled = o.alc == "on";
  config.planner.alc.epsilon = o.epsilon;
  config.planner.alc.finish_loop_age_s = o.finish_loop_age_s;
  config.planner.cost.w_dir = o.w_dir;
  config.planner.trajectory.lead_in_at_speed = o.lead_in == "at-speed";
  config.planner.safety.enabled = o.safety == "on";
  config.planner.safety.recent.window_s = o.safety_window_s;
  config.planner.safety.max_window_s = o.safety_max_window_s;
  config.planner.safety.seen_free_is_free = o.safety_seen_free == "on";
  setMapThin(config.planner.safety, o.safety_map_thin);
  config.planner.safety.recent.newer_free_clears = o.safety_free_clears == "on";
  config.planner.safety.vertical_margin_m = o.safety_vertical_margin_m;
  config.planner.safety.vertical_margin_sigmas = o.safety_vertical_sigmas;
  config.planner.safety.max_vertical_margin_m = o.safety_vertical_margin_max_m;
  config.planner.safety.look_side_m = o.safety_look_side_m;
  config.planner.safety.look_steep = o.safety_look_steep == "on";
  config.planner.safety.seen_until_arrival = o.safety_seen_until_arrival == "on";
  config.planner.safety.path_drift = parsePathDrift(o.safety_path_drift);
  config.planner.safety.near_drift_tolerance_m = o.safety_near_tolerance_m;
  config.planner.frontier.min_cluster_size = o.min_cluster_size;
  config.planner.revisit_rounds = o.revisit_rounds;
  config.planner.viewpoint.look_into_unknown = o.look_into_unknown;
  config.planner.viewpoint.vertical_into_unknown = o.vertical_frontier == planner::viewScoreName(true);
  config.planner.viewpoint.fallback.min_visible_samples = o.fallback_min_visible;
  config.planner.viewpoint.fallback.large_cluster_voxels = o.fallback_large_voxels;
  config.planner.viewpoint.fallback.large_min_visible_samples = o.fallback_large_min_visible;
  config.planner.late_large_min_visible_samples = o.fallback_large_min_visible_late;
  config.planner.final_min_cluster_size = o.final_min_cluster_size;
  for (auto scope :
       {planner::FinalSweepScope::All, planner::FinalSweepScope::Pockets, planner::FinalSweepScope::PocketsOnce})
    if (o.final_sweep == planner::toString(scope)) config.planner.final_sweep = scope;
  if (!o.box.empty())
    config.planner.box_W = Eigen::AlignedBox3d(Vec3d(o.box[0], o.box[1], o.box[2]), Vec3d(o.box[3], o.box[4], o.box[5]));
  config.start.position_W = o.start.empty() ? sim::defaultStartPosition(world, config.planner.box_W)
                                     : Vec3d(o.start[0], o.start[1], o.start[2]);
  config.start.yaw_rad = o.start_yaw;

  std::string description =
      "vdbmap explore --world " + o.world.string() + " --drift " + o.drift + " --seed " + std::to_string(o.seed) +
      " --mode " + o.mode + " --min-cluster-size " + std::to_string(o.min_cluster_size) + " --final-min-cluster-size " +
      std::to_string(o.final_min_cluster_size) + " --final-sweep " + o.final_sweep + " --view-score " +
      planner::viewScoreName(o.look_into_unknown) + " --vertical-frontier " + o.vertical_frontier +
      " --fallback-min-visible " + std::to_string(o.fallback_min_visible) + " --fallback-large-voxels " +
      std::to_string(o.fallback_large_voxels) + " --fallback-large-min-visible " +
      std::to_string(o.fallback_large_min_visible) + " --fallback-large-min-visible-late " +
      std::to_string(o.fallback_large_min_visible_late) + " --revisit-rounds " + std::to_string(o.revisit_rounds) +
      " --w-dir " + std::to_string(o.w_dir) + " --lead-in " + o.lead_in + " --budgets " + o.budgets +
      (o.no_initial_turn ? " --no-initial-turn" : "") + " --alc " + o.alc +
      (config.planner.alc_enabled
           ? " --epsilon " + std::to_string(o.epsilon) + " --finish-loop-age " + std::to_string(o.finish_loop_age_s)
           : std::string()) +
      " --safety " + o.safety +
      (config.planner.safety.enabled
           ? " --safety-window-s " + std::to_string(o.safety_window_s) + " --safety-max-window-s " +
                 std::to_string(o.safety_max_window_s) + " --safety-seen-free " + o.safety_seen_free +
                 " --safety-map-thin " + o.safety_map_thin + " --safety-free-clears " + o.safety_free_clears +
                 " --safety-vertical-margin " + std::to_string(o.safety_vertical_margin_m) +
                 " --safety-vertical-sigmas " + std::to_string(o.safety_vertical_sigmas) +
                 " --safety-vertical-margin-max " + std::to_string(o.safety_vertical_margin_max_m) +
                 " --safety-look-side " + std::to_string(o.safety_look_side_m) + " --safety-look-steep " +
                 o.safety_look_steep + " --safety-seen-until-arrival " + o.safety_seen_until_arrival +
                 " --safety-path-drift " + o.safety_path_drift + " --safety-near-tolerance " +
                 std::to_string(o.safety_near_tolerance_m)
           : std::string());
  const Eigen::AlignedBox3d& b = config.planner.box_W;
  std::fprintf(stderr, "%s: %zu triangles; box [%.2f %.2f %.2f]-[%.2f %.2f %.2f]; start (%.2f %.2f %.2f)\n",
               o.world.c_str(), world.stats().triangles, b.min().x(), b.min().y(), b.min().z(), b.max().x(),
               b.max().y(), b.max().z(), config.start.position_W.x(), config.start.position_W.y(), config.start.position_W.z());

  sim::ExplorationRunConfig ro;
  ro.overwrite = o.overwrite;
  ro.description = description;
  ro.world = std::filesystem::absolute(requireWorld(o.world)).lexically_normal().string();
  ExploreProgress progress;
  ro.progress = [&](const sim::ExplorationProgress& p) { progress.update(p); };
  ro.report = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  const sim::ExplorationSummary s = sim::exploreToFolder(world, config, o.output, ro);
  progress.finish();
  std::printf("%s: %s after %.1f s (%.1f m), coverage %.3f, %zu collisions, %zu loop closures\n", o.output.c_str(),
              s.finished ? "finished" : "time limit reached", s.exploration_time_s, s.path_length_m, s.coverage,
              s.collisions, s.loop_closures);
  if (s.finished && !s.complete)
    std::printf(
        "incomplete: the planner found nothing more it could reach at coverage %.3f, below %.2f "
        "(the camera saw %.3f of the observable surface)\n",
        s.coverage, sim::kCompleteCoverage, s.coverage_seen);
  if (s.alc_enabled)
    std::printf("active loop closure: %zu detours (%zu closed a loop, %zu given up), %.1f s on detours\n",
                s.alc_detours, s.alc_detour_loops, s.alc_give_ups, s.alc_time_s);
  if (config.planner.safety.enabled)
    std::printf("safety layer: %zu emergency stops, %zu stops to look along the way\n", s.emergency_stops,
                s.look_stops);
  std::printf("planner %.1f ms median, %.1f ms max per replan; %zu frames, %zu keyframes kept; map RMSE %.4f m, "
              "completeness %.3f; %.0f s wall\n",
              s.planner_ms_median, s.planner_ms_max, s.frames_total, s.keyframes_kept, s.accuracy_rmse_m,
              s.completeness, s.wall_s);
  if (o.report) {
    const Stopwatch watch;
    report::ReportConfig rc;
    rc.command = description;
    const report::ReportStats r = report::writeReport(o.output, o.output / "report.html", rc);
    std::printf("report %s: %.1f MB in %.1f s\n", (o.output / "report.html").c_str(), double(r.bytes) / 1e6, watch.s());
  }
}

const Registration registration("explore", [](CLI::App& app) {
  auto o = std::make_shared<ExploreOptions>();
  CLI::App* sub = app.add_subcommand(
      "explore", "Explore a world with the simulated vehicle, the mapper and the exploration planner in closed loop");
  sub->option_defaults()->always_capture_default();
  addWorldOption(*sub, o->world);
  addDriftOption(*sub, o->drift);
  sub->add_option("--seed", o->seed, "Seed of the drift, the loop-edge noise and the planner's sampling");
  sub->add_option("--voxel-size", o->voxel_size_m, "Voxel edge in metres")->check(CLI::Range(0.02, 1.0));
  sub->add_option("--max-time-s", o->max_time_s, "Simulated time limit in seconds")->check(CLI::Range(1.0, 1e5));
  sub->add_option("--mode", o->mode, "Consistency under corrections: none, submap, all, keyframes")
      ->check(CLI::IsMember({"none", "submap", "all", "keyframes"}));
  sub->add_option("--loop-closure", o->loop_closure, "Correction on loop closure: pose-graph optimization, ground truth, or none")
      ->check(CLI::IsMember({"pgo", "perfect", "off"}));
  sub->add_option("--ceiling", o->ceiling_m,
                  "Cut the world at this height and close it with a flat ceiling there (metres; 0 keeps the mesh as is)")
      ->check(CLI::Range(0.0, 1e3));
  sub->add_option("--start", o->start, "Start position x,y,z (default: the clear point nearest the box's centre, 1 m up)")
      ->delimiter(',')
      ->expected(3);
  sub->add_option("--start-yaw", o->start_yaw, "Start yaw in radians");
  sub->add_option("--box", o->box, "Exploration box xmin,ymin,zmin,xmax,ymax,zmax (default: the world's bounds)")
      ->delimiter(',')
      ->expected(6);
  sub->add_option("--alc", o->alc,
                  "Active loop closure: on, or off (the default: plain FUEL exploration, no detours to old places)")
      ->check(CLI::IsMember({"on", "off"}));
  sub->add_option("--epsilon", o->epsilon,
                  "ALC: take the loop-closure detour when it costs at most (1 + epsilon) times the frontier tour")
      ->check(CLI::Range(0.0, 100.0));
  sub->add_option(
         "--finish-loop-age", o->finish_loop_age_s,
         "ALC: when exploration would finish and no loop has closed for this many seconds, fly back to a "
         "nearby place flown before to close one more (at most " +
             std::to_string(planner::AlcConfig{}.max_finish_detours) +
             " times per flight), so the drift of the last stretch is corrected in the map (0: finish at once)")
      ->check(CLI::Range(0.0, 1e6));
  sub->add_option("--safety", o->safety,
                  "The drift-free safety layer: the last seconds of depth frames are obstacles over the global map, "
                  "a trajectory they see blocked is replanned at once (an emergency stop), and the vehicle brakes "
                  "and looks before flying into space they have not seen free")
      ->check(CLI::IsMember({"on", "off"}));
  sub->add_option("--safety-window-s", o->safety_window_s,
                  "The safety layer trusts the depth frames of at least the last this many seconds; longer, up to "
                  "--safety-max-window-s, while the drift level's noise keeps them within 0.2 m of where they "
                  "are (s1: the longest; s2: about 29 s; s3 and s4: this)")
      ->check(CLI::Range(0.1, 600.0));
  sub->add_option("--safety-max-window-s", o->safety_max_window_s,
                  "The longest the safety layer's window may widen to under little drift (older frames are kept "
                  "two a second); at most --safety-window-s: no widening")
      ->check(CLI::Range(0.1, 600.0));
  sub->add_option("--safety-seen-free", o->safety_seen_free,
                  "With the safety layer, paths also read free the space the recent frames saw free, whatever the "
                  "global map says (a door that drift closed in the map, seen open now, is open)")
      ->check(CLI::IsMember({"on", "off"}));
  sub->add_option("--safety-map-thin", o->safety_map_thin, kSafetyMapThinHelp)
      ->check(CLI::IsMember(kSafetyMapThinValues));
  sub->add_option("--safety-free-clears", o->safety_free_clears,
                  "With the safety layer, a recent frame's surface voxel that a newer frame saw free is no longer an "
                  "obstacle (the newest observation wins: within the window drift still moves what older frames saw)")
      ->check(CLI::IsMember({"on", "off"}));
  sub->add_option("--safety-vertical-margin", o->safety_vertical_margin_m,
                  "With the safety layer under drift (s2-s4), paths keep this much more from the global map's "
                  "surfaces straight above and below (metres): the camera sees neither, so no look finds a beam "
                  "overhead that drift brought closer. It grows with the map's age (--safety-vertical-sigmas)")
      ->check(CLI::Range(0.0, 2.0));
  sub->add_option("--safety-vertical-sigmas", o->safety_vertical_sigmas,
                  "The vertical margin grows to this many sigmas of the drift level's vertical drift over the time "
                  "flown (a surface mapped that long ago may sit that much off), from --safety-vertical-margin up "
                  "to --safety-vertical-margin-max")
      ->check(CLI::Range(0.0, 10.0));
  sub->add_option("--safety-vertical-margin-max", o->safety_vertical_margin_max_m,
                  "The most the vertical margin grows to (metres); it never falls below --safety-vertical-margin")
      ->check(CLI::Range(0.0, 2.0));
  sub->add_option("--safety-look-side", o->safety_look_side_m,
                  "With the safety layer, the points this far to the left and right of the way ahead must have been "
                  "seen too, not only the way's middle (metres; 0: the middle only): under drift a wall the global "
                  "map holds elsewhere may stand beside a way seen free")
      ->check(CLI::Range(0.0, 5.0));
  sub->add_option("--safety-look-steep", o->safety_look_steep,
                  "With the safety layer, a point of the way ahead above or below the camera's view (a steep climb "
                  "or descent) is checked at the steepest point of its vertical line in view (on), or not at all "
                  "(off)")
      ->check(CLI::IsMember({"on", "off"}));
  sub->add_option("--safety-seen-until-arrival", o->safety_seen_until_arrival,
                  "With the safety layer, a point of the way counts as seen only by frames young enough when the "
                  "vehicle gets there: the recent window, or shorter where the declared drift of that age exceeds "
                  "the tolerance (on); or by any frame in the window (off)")
      ->check(CLI::IsMember({"on", "off"}));
  sub->add_option("--safety-path-drift", o->safety_path_drift, kSafetyPathDriftHelp)
      ->check(CLI::IsMember({"off", "near", "on"}));
  sub->add_option("--safety-near-tolerance", o->safety_near_tolerance_m, kSafetyNearToleranceHelp)
      ->check(CLI::Range(0.0, 10.0));
  sub->add_option("--min-cluster-size", o->min_cluster_size,
                  "Frontier clusters with fewer voxels are ignored (FUEL's cluster_min); smaller values chase the "
                  "small unknown pockets of cluttered places (e.g. 50 for shelving)")
      ->check(CLI::Range(1, 100000000));
  sub->add_option("--final-min-cluster-size", o->final_min_cluster_size,
                  "When no cluster is left to visit, lower the min cluster size to this once and visit the small "
                  "clusters in a final sweep (0: off; only values below --min-cluster-size act)")
      ->check(CLI::Range(0, 100000000));
  sub->add_option("--final-sweep", o->final_sweep,
                  "Which small clusters the final sweep visits: all (every one, also those that appear during the "
                  "sweep, e.g. where a loop correction moved a surface), pockets (those left when it began, and "
                  "what remains of them, until covered or blacklisted), once (each such pocket until one visit of "
                  "it is over: shorter sweeps, fewer loop closures)")
      ->check(CLI::IsMember({"all", "pockets", "once"}));
  addViewScoreOption(*sub, o->look_into_unknown);
  sub->add_option("--vertical-frontier", o->vertical_frontier,
                  "With --view-score voxel, how a frontier voxel whose unknown neighbours lie only above or below "
                  "it counts for a viewpoint until no target is left: into-unknown (only when the camera looks into "
                  "that unknown: the top of a shelf board seen from its height does not count) or voxel (FUEL's "
                  "rule: seen is enough). From the first time no target is left, FUEL's rule, and the clusters "
                  "left without a viewpoint get theirs")
      ->check(CLI::IsMember({planner::viewScoreName(true), planner::viewScoreName(false)}));
  sub->add_option("--fallback-min-visible", o->fallback_min_visible,
                  "A fallback viewpoint (for a cluster no ring viewpoint sees) passes when it sees more than this "
                  "many of the cluster's voxels (or half of a small cluster): lower lets shelving whose goods show "
                  "a few voxels per gap be looked into")
      ->check(CLI::Range(0, 1000000));
  sub->add_option("--fallback-large-min-visible", o->fallback_large_min_visible,
                  "For a cluster of at least --fallback-large-voxels frontier voxels, the fallback threshold is this "
                  "when lower than --fallback-min-visible: a large cluster seen a few voxels per gap is looked into, "
                  "small ones keep the higher threshold")
      ->check(CLI::Range(0, 1000000));
  sub->add_option("--fallback-large-voxels", o->fallback_large_voxels,
                  "How many frontier voxels make a cluster large for --fallback-large-min-visible")
      ->check(CLI::Range(1, 1000000000));
  sub->add_option("--fallback-large-min-visible-late", o->fallback_large_min_visible_late,
                  "From the first time no target is left (where the final sweep begins), a cluster of at least "
                  "--fallback-large-voxels frontier voxels takes this fallback threshold when lower, and those still "
                  "without a viewpoint are looked at again: shelving seen a few voxels per gap is looked into at the "
                  "end (15 or more: off)")
      ->check(CLI::Range(0, 1000000));
  sub->add_option("--revisit-rounds", o->revisit_rounds,
                  "Times to retry, before finishing, the clusters that were blacklisted or had no viewpoint: one "
                  "more try each, with viewpoints computed in the map as it is then")
      ->check(CLI::Range(0, 100));
  sub->add_option("--w-dir", o->w_dir,
                  "Seconds added to a target's cost per radian its path leaves away from the current velocity "
                  "(FUEL's w_dir: larger values turn back toward targets behind less often, e.g. 3 reached 0.95 "
                  "coverage sooner at s1 but closed fewer loops at s3 with --alc on)")
      ->check(CLI::Range(0.0, 1000.0));
  sub->add_option("--lead-in", o->lead_in,
                  "How a replan while flying turns onto a path that leaves across the velocity: at-speed (an arc "
                  "from the vehicle at its speed where that arc is clear, else as straight) or straight (lead-ins "
                  "along the velocity that brake into a tighter turn)")
      ->check(CLI::IsMember({"at-speed", "straight"}));
  sub->add_option("--budgets", o->budgets,
                  "How path searches, tours and re-integration cycles are limited: counted (iterations and "
                  "frames: the same command gives the same run on any machine) or wall-clock (time limits, as on "
                  "a robot: runs vary with the machine's load)")
      ->check(CLI::IsMember({"counted", "wall-clock"}));
  sub->add_flag("--no-initial-turn", o->no_initial_turn, "Skip the turn on the spot at take-off");
  sub->add_flag("--overwrite", o->overwrite, "Replace a run already in RUNDIR");
  sub->add_flag("--report", o->report, "Also write RUNDIR/report.html (as `vdbmap report RUNDIR`)");
  sub->add_option("-o,--output", o->output, "Run folder to write")->required();
  sub->callback([o] { runExplore(*o); });
});

}  // namespace
}  // namespace vdbmap::cli
