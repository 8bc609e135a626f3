// The worlds a benchmark explores: mesh files, or generated offices named by seed and size, so that
// a planner or ALC result can be checked on layouts that nobody tuned on (office_world.hpp).
//
// Specs, as `vdbmap bench explore --worlds` and `vdbmap bench alc --worlds` take them:
//   PATH                  a mesh file (PLY, OBJ, OFF), cut and capped at `ceiling_m` when positive;
//   office:SEED[:XxY]     one generated office, e.g. office:3:20x16 (default size 30 x 16 m);
//   office:A-B[:XxY]      the offices of seeds A..B (at most 100), e.g. office:101-106:20x16.
// A generated office is cut and capped at its own ceiling.
#pragma once

#include "vdbmap/sim/office_world.hpp"
#include "vdbmap/sim/world.hpp"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace vdbmap::sim {

struct BenchmarkWorld {
  std::string name;                         ///< run folders' prefix and table rows; unique in a benchmark
  std::filesystem::path mesh;               ///< a mesh file, or empty for `office`
  WorldConfig world;                        ///< for a mesh file
  std::optional<OfficeWorldConfig> office;  ///< a generated office instead of a file

  /// Throws std::invalid_argument naming the world when it has neither a mesh nor a valid office.
  void validate() const;
};

/// The worlds of one spec (above). Throws std::invalid_argument naming a malformed spec.
std::vector<BenchmarkWorld> parseBenchmarkWorlds(const std::string& spec, double ceiling_m);

/// Throws std::invalid_argument when `worlds` is empty, a world is invalid or two share a name.
void validateBenchmarkWorlds(const std::vector<BenchmarkWorld>& worlds, const std::string& owner);

/// Loads the mesh file or generates the office (throws as World::load / generateOffice).
World loadBenchmarkWorld(const BenchmarkWorld& world);

/// The mesh file a run's report can colour the map by: the world's own file, or the generated
/// office written to out_dir/worlds/<name>.ply. Throws std::runtime_error on I/O errors.
std::filesystem::path benchmarkWorldFile(const BenchmarkWorld& world, const std::filesystem::path& out_dir);

}  // namespace vdbmap::sim
