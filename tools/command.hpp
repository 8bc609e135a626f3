// Subcommand registry of the `vdbmap` program: each cmd_<name>.cpp registers itself with a static
// `vdbmap::cli::Registration`, so adding a subcommand never edits main.cpp. Groups of subcommands
// (`vdbmap bench drift`, `vdbmap bench alc`) work the same way one level down: the group's file
// registers the group, and each member registers itself with a `GroupRegistration`.
#pragma once

#include <CLI/CLI.hpp>

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

}  // namespace vdbmap::cli
