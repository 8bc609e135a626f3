// `--world` and the embedded default world (data/worlds/small_house), so that `vdbmap explore` runs
// from a clone or an install alone.
#include "command.hpp"

#include <stdexcept>
#include <system_error>

namespace vdbmap::cli {
namespace {
const std::filesystem::path kDefaultWorld = "worlds/small_house/small_house_visual_mesh.ply";

/// Where the default world may be, in order: installed beside the program, then the source tree.
std::vector<std::filesystem::path> defaultWorldCandidates() {
  std::vector<std::filesystem::path> candidates;
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) candidates.push_back(exe.parent_path().parent_path() / "share" / "vdbmap" / kDefaultWorld);
  candidates.push_back(std::filesystem::path(VDBMAP_SOURCE_DATA_DIR) / kDefaultWorld);
  return candidates;
}
}  // namespace

std::filesystem::path defaultWorldPath() {
  for (const auto& candidate : defaultWorldCandidates()) {
    std::error_code ec;
    if (std::filesystem::is_regular_file(candidate, ec)) return candidate;
  }
  return {};
}

CLI::Option* addWorldOption(CLI::App& sub, std::filesystem::path& world) {
  world = defaultWorldPath();
  return sub
      .add_option("--world", world,
                  "World mesh (PLY, OBJ, OFF), metres, z up (default: the embedded AWS small house, "
                  "data/worlds/small_house)")
      ->check(CLI::ExistingFile);
}

const std::filesystem::path& requireWorld(const std::filesystem::path& world) {
  if (!world.empty()) return world;
  std::string where;
  for (const auto& candidate : defaultWorldCandidates()) where += "\n  " + candidate.string();
  throw std::runtime_error("no --world given, and the default world is not at any of:" + where);
}

std::vector<std::string> benchmarkWorldSpecs(const std::vector<std::string>& specs) {
  std::vector<std::string> out;
  for (const std::string& spec : specs.empty() ? std::vector<std::string>{"house"} : specs)
    out.push_back(spec == "house" ? requireWorld(defaultWorldPath()).string() : spec);
  return out;
}

}  // namespace vdbmap::cli
