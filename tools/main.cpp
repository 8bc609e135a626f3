// `vdbmap`: the command-line front end. Parsing and printing only; the work is in the libraries.
#include "command.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/io/errors.hpp"
#include "vdbmap/version.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <iostream>
#include <map>
#include <new>
#include <string>

namespace vdbmap::cli {
namespace {
std::map<std::string, CommandSetup>& registry() {
  static std::map<std::string, CommandSetup> commands;
  return commands;
}
std::map<std::string, std::map<std::string, CommandSetup>>& groupRegistry() {
  static std::map<std::string, std::map<std::string, CommandSetup>> groups;
  return groups;
}
}  // namespace

Registration::Registration(std::string name, CommandSetup setup) {
  registry().emplace(std::move(name), std::move(setup));
}

std::vector<std::pair<std::string, CommandSetup>> registeredCommands() {
  return {registry().begin(), registry().end()};
}

GroupRegistration::GroupRegistration(std::string group, std::string name, CommandSetup setup) {
  groupRegistry()[std::move(group)].emplace(std::move(name), std::move(setup));
}

std::vector<std::pair<std::string, CommandSetup>> registeredCommands(const std::string& group) {
  const auto it = groupRegistry().find(group);
  if (it == groupRegistry().end()) return {};
  return {it->second.begin(), it->second.end()};
}
}  // namespace vdbmap::cli

namespace {

// "vdbmap integrate", or "vdbmap bench drift" for a member of a group: the command that was running.
std::string runningCommand(const CLI::App& app) {
  std::string name = "vdbmap";
  for (const CLI::App* sub = &app; !sub->get_subcommands().empty();) {
    sub = sub->get_subcommands().front();
    name += " " + sub->get_name();
  }
  return name;
}

/// Keeps the memory a frame frees for the next frame. A frame's buffers (the quantized depth
/// image, 1.2 MB at 640x480; the loader's decoded PNG; hit and index tables) are freed and
/// allocated again every frame; with glibc's defaults the larger ones come from fresh mappings or
/// from heap space handed back to the system in between, so their pages fault again every frame:
/// a fifth of a 7-Scenes frame's time at 5 cm (docs/results/realtime_7scenes.md, stop 53). The
/// process keeps its peak instead. A GLIBC_TUNABLES setting of malloc's own is left to rule.
void keepFreedMemory() {
#if defined(__GLIBC__)
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  if (tunables && std::strstr(tunables, "glibc.malloc.")) return;
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's largest
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
}

}  // namespace

int main(int argc, char** argv) {
  keepFreedMemory();
  CLI::App app{"vdbmap: globally consistent TSDF mapping on OpenVDB, with re-integration, "
               "frame pruning and exploration planning"};
  app.require_subcommand(1);
  // Ctrl-C or a kill during a save removes its temporaries; the files it replaces stay as they were.
  vdbmap::removeTemporariesOnSignals();
  app.set_version_flag("--version", std::string("vdbmap ") + vdbmap::kVersion);
  for (auto& [name, setup] : vdbmap::cli::registeredCommands()) setup(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::bad_alloc&) {
    // The readers check declared sizes against the file before allocating, so this is a real
    // shortage (or an input that passes those checks and is still too large for this machine).
    std::cerr << "vdbmap: error: out of memory (in '" << runningCommand(app)
              << "': the input or the requested map is too large for this machine's memory)\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "vdbmap: error: " << vdbmap::io::escapeControl(e.what(), /*keep_line_breaks=*/true) << "\n";
    return 1;
  }
  return 0;
}
