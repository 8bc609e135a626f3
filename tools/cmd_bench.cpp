// `vdbmap bench <name>`: the group of benchmark subcommands; each member (cmd_bench_<name>.cpp)
// registers itself with a GroupRegistration("bench", ...).
#include "command.hpp"

namespace vdbmap::cli {
namespace {
const Registration registration("bench", [](CLI::App& app) {
  CLI::App* bench = app.add_subcommand("bench", "Benchmarks of the paper, each in one command");
  bench->require_subcommand(1);
  for (auto& [name, setup] : registeredCommands("bench")) setup(*bench);
});
}  // namespace
}  // namespace vdbmap::cli
