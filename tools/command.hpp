// Subcommand registry of the `vdbmap` program: each cmd_<name>.cpp registers itself with a static
// `vdbmap::cli::Registration`, so adding a subcommand never edits main.cpp.
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

}  // namespace vdbmap::cli
