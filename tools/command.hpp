// Subcommand registry of the `vdbmap` program: each cmd_<name>.cpp registers itself with a static
// `vdbmap::cli::Registration`, so adding a subcommand never edits main.cpp. Groups of subcommands
// (`vdbmap bench drift`, `vdbmap bench alc`) work the same way one level down: the group's file
// registers the group, and each member registers itself with a `GroupRegistration`.
#pragma once

#include "vdbmap/planner/exploration_manager.hpp"
#include "vdbmap/planner/viewpoint.hpp"

#include <CLI/CLI.hpp>

#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace vdbmap::cli {

/// Adds one subcommand to `app` and sets its callback.
using CommandSetup = std::function<void(CLI::App& app)>;

struct Registration {
  Registration(std::string name, CommandSetup setup);
};

/// Every registered subcommand, sorted by name (so --help lists them alphabetically).
std::vector<std::pair<std::string, CommandSetup>> registeredCommands();

/// A member of a group: its setup receives the group's CLI::App.
struct GroupRegistration {
  GroupRegistration(std::string group, std::string name, CommandSetup setup);
};

/// The members of a group, sorted by name; the group's setup adds them.
std::vector<std::pair<std::string, CommandSetup>> registeredCommands(const std::string& group);

/// The paper's odometry drift levels (Table I), as the simulator's commands spell them.
inline const std::vector<std::string>& driftLevels() {
  static const std::vector<std::string> levels{"s1", "s2", "s3", "s4"};
  return levels;
}

/// The embedded default world (data/worlds/small_house, the AWS small house): the installed copy
/// beside the program (<prefix>/share/vdbmap/worlds/...) or the source tree's; empty when neither
/// exists.
std::filesystem::path defaultWorldPath();

/// `--world`, the world mesh the simulator's commands fly through (an existing file); defaults to
/// defaultWorldPath(). The command throws, naming where it looked, when neither is there.
CLI::Option* addWorldOption(CLI::App& sub, std::filesystem::path& world);

/// The world to load: `world` as given, or the error that no default world was found.
const std::filesystem::path& requireWorld(const std::filesystem::path& world);

/// The world specs of a benchmark's `--worlds` (sim/benchmark_world.hpp) with `house` replaced by
/// the embedded default world's path; none given means the house alone. Throws as requireWorld
/// when the house is asked for and not found.
std::vector<std::string> benchmarkWorldSpecs(const std::vector<std::string>& specs);

/// The help of `--safety-near-tolerance` (SafetyConfig::near_drift_tolerance_m), as `vdbmap explore`
/// and the benchmarks give it.
inline constexpr const char* kSafetyNearToleranceHelp =
    "With the safety layer under declared drift, where the way passes within the clearance plus 0.2 m of a "
    "recent surface it counts as seen only by frames whose drift at arrival stays within this many metres "
    "(s3: 0.1 m keeps frames 2.6 s old): a surface seen seconds before may stand nearer than it looks, so "
    "the vehicle faces the way or looks before it passes (0: off, the same frames count as elsewhere; else below "
    "the 0.2 m the window's frames may drift)";

/// `--view-score into-unknown|voxel` (planner::ViewpointConfig::look_into_unknown, named by
/// planner::viewScoreName), as `vdbmap explore` and the benchmarks take it.
inline void addViewScoreOption(CLI::App& sub, bool& look_into_unknown) {
  sub.add_option_function<std::string>(
         "--view-score",
         [&look_into_unknown](const std::string& value) { look_into_unknown = value == planner::viewScoreName(true); },
         "What a viewpoint counts as seeing a frontier voxel, to score viewpoints and judge visits: into-unknown (the "
         "camera looks into an unknown neighbour of it, which the visit then makes known) or voxel (FUEL: it sees the "
         "free voxel itself, also where the unknown beside it stays out of sight, e.g. on a shelf board seen edge-on)")
      ->check(CLI::IsMember({planner::viewScoreName(true), planner::viewScoreName(false)}))
      ->default_str(planner::viewScoreName(look_into_unknown));
}

/// `--safety-path-drift`'s values, as planner::toString names them.
inline planner::PathDriftScope parsePathDrift(const std::string& value) {
  for (const auto scope :
       {planner::PathDriftScope::Off, planner::PathDriftScope::NearSurfaces, planner::PathDriftScope::Everywhere})
    if (value == planner::toString(scope)) return scope;
  throw std::invalid_argument("--safety-path-drift: '" + value + "' is not off, near or on");
}

inline constexpr const char* kSafetyPathDriftHelp =
    "With the safety layer under declared drift, a frame's drift when the vehicle gets to a point of its way also "
    "counts the path flown since the frame (the yaw error turns every metre flown), so at speed the way must have "
    "been seen more lately (s3: about 3 s at 1.5 m/s instead of 9.4 s): on (at every point of the way), near (where "
    "the way passes near a recent surface) or off (by the frame's age alone)";

/// `--safety-map-thin`'s values: on (SafetyConfig::map_thin_obstacles), without-drift
/// (map_thin_without_drift alone) or off (neither).
inline std::string mapThinName(const planner::SafetyConfig& safety) {
  return safety.map_thin_obstacles ? "on" : safety.map_thin_without_drift ? "without-drift" : "off";
}
inline void setMapThin(planner::SafetyConfig& safety, const std::string& value) {
  safety.map_thin_obstacles = value == "on";
  safety.map_thin_without_drift = value == "without-drift";
}
inline const std::vector<std::string> kSafetyMapThinValues = {"on", "without-drift", "off"};
inline const char* const kSafetyMapThinHelp =
    "With the safety layer, paths also read the global map's thin structure as obstacles: on; without-drift (the "
    "default): only when the declared odometry does not drift (s1), where a surface seen again lands where it was; "
    "off: only the recent frames' surfaces stand for it (under drift, end points of a surface seen at another drift "
    "stay where they landed, and read as a wall in free space)";

/// `--safety on|off`, `--safety-seen-free on|off`, `--safety-map-thin on|without-drift|off`,
/// `--safety-near-tolerance M` and `--safety-path-drift off|near|on` of the benchmarks (as `vdbmap
/// explore`'s).
inline void addSafetyOptions(CLI::App& sub, std::string& safety, std::string& seen_free, std::string& map_thin,
                             double& near_tolerance_m, std::string& path_drift) {
  sub.add_option("--safety", safety, "The drift-free safety layer of recent depth frames (as vdbmap explore --safety)")
      ->check(CLI::IsMember({"on", "off"}));
  sub.add_option("--safety-seen-free", seen_free,
                 "With the safety layer, paths also read free the space the recent frames saw free (as vdbmap "
                 "explore --safety-seen-free)")
      ->check(CLI::IsMember({"on", "off"}));
  sub.add_option("--safety-map-thin", map_thin, kSafetyMapThinHelp)->check(CLI::IsMember(kSafetyMapThinValues));
  sub.add_option("--safety-near-tolerance", near_tolerance_m, kSafetyNearToleranceHelp)->check(CLI::Range(0.0, 10.0));
  sub.add_option("--safety-path-drift", path_drift, kSafetyPathDriftHelp)->check(CLI::IsMember({"off", "near", "on"}));
}

/// `--drift`, one of driftLevels().
inline CLI::Option* addDriftOption(CLI::App& sub, std::string& drift) {
  return sub.add_option("--drift", drift, "Odometry drift level of the paper's Table I")
      ->check(CLI::IsMember(driftLevels()));
}

}  // namespace vdbmap::cli
