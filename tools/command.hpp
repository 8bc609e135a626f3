// Subcommand registry of the `vdbmap` program: each cmd_<name>.cpp registers itself with a static
// `vdbmap::cli::Registration`, so adding a subcommand never edits main.cpp. Groups of subcommands
// (`vdbmap bench drift`, `vdbmap bench alc`) work the same way one level down: the group's file
// registers the group, and each member registers itself with a `GroupRegistration`.
#pragma once

#include <CLI/CLI.hpp>

#include <filesystem>
#include <functional>
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

/// `--world`, the world mesh the simulator's commands fly through (required, an existing file).
inline CLI::Option* addWorldOption(CLI::App& sub, std::filesystem::path& world) {
  return sub.add_option("--world", world, "World mesh (PLY, OBJ, OFF), metres, z up")
      ->required()
      ->check(CLI::ExistingFile);
}

/// `--drift`, one of driftLevels().
inline CLI::Option* addDriftOption(CLI::App& sub, std::string& drift) {
  return sub.add_option("--drift", drift, "Odometry drift level of the paper's Table I")
      ->check(CLI::IsMember(driftLevels()));
}

}  // namespace vdbmap::cli
