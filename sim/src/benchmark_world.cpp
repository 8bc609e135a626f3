#include "vdbmap/sim/benchmark_world.hpp"

#include "vdbmap/io/mesh_io.hpp"

#include <cstdlib>
#include <map>
#include <sstream>
#include <stdexcept>

namespace vdbmap::sim {

void BenchmarkWorld::validate() const {
  if (office)
    office->validate();
  else if (mesh.empty())
    throw std::invalid_argument("world " + name + " has neither a mesh nor an office");
  world.validate();
}

namespace {

/// A positive decimal seed, or 0 for anything else.
std::uint64_t parseSeed(const std::string& text) {
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos || text.size() > 18) return 0;
  return std::strtoull(text.c_str(), nullptr, 10);
}

constexpr std::uint64_t kMaxOfficesPerSpec = 100;

}  // namespace

std::vector<BenchmarkWorld> parseBenchmarkWorlds(const std::string& spec, double ceiling_m) {
  if (spec.rfind("office:", 0) != 0) {
    BenchmarkWorld w;
    w.mesh = spec;
    w.name = w.mesh.stem().string();
    if (ceiling_m > 0.0) {
      w.world.ceiling_clip_z_m = ceiling_m;
      w.world.cap_ceiling = true;
    }
    return {w};
  }
  const auto fail = [&](const std::string& why) { throw std::invalid_argument("world '" + spec + "': " + why); };
  const std::string rest = spec.substr(7);
  const std::size_t colon = rest.find(':');
  const std::string seeds = rest.substr(0, colon);
  const std::size_t dash = seeds.find('-');
  const std::uint64_t first = parseSeed(seeds.substr(0, dash));
  const std::uint64_t last = dash == std::string::npos ? first : parseSeed(seeds.substr(dash + 1));
  if (first == 0 || last == 0) fail("expected office:SEED[:XxY] or office:A-B[:XxY] with seeds >= 1");
  if (last < first || last - first >= kMaxOfficesPerSpec)
    fail("a seed range A-B needs A <= B and at most " + std::to_string(kMaxOfficesPerSpec) + " seeds");
  OfficeWorldConfig office;
  std::string size_suffix;
  if (colon != std::string::npos) {
    const std::string size = rest.substr(colon + 1);
    double x = 0.0, y = 0.0;
    char sep = 0, tail = 0;
    std::istringstream in(size);
    if (!(in >> x >> sep >> y) || sep != 'x' || (in >> tail)) fail("the size must read XxY in metres, e.g. 20x16");
    office.size_x_m = x;
    office.size_y_m = y;
    size_suffix = "_" + size;
  }
  std::vector<BenchmarkWorld> worlds;
  for (std::uint64_t seed = first; seed <= last; ++seed) {
    office.seed = seed;
    try {
      office.validate();
    } catch (const std::invalid_argument& e) {
      fail(e.what());
    }
    BenchmarkWorld w;
    w.office = office;
    w.name = "office" + std::to_string(seed) + size_suffix;
    worlds.push_back(w);
  }
  return worlds;
}

void validateBenchmarkWorlds(const std::vector<BenchmarkWorld>& worlds, const std::string& owner) {
  if (worlds.empty()) throw std::invalid_argument(owner + ".worlds must name at least one world");
  std::map<std::string, int> names;
  for (const BenchmarkWorld& w : worlds) {
    try {
      w.validate();
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(owner + ".worlds: " + e.what());
    }
    if (++names[w.name] > 1) throw std::invalid_argument(owner + ".worlds: " + w.name + " is listed twice");
  }
}

World loadBenchmarkWorld(const BenchmarkWorld& w) {
  if (!w.office) return World::load(w.mesh, w.world);
  WorldConfig wc;
  wc.ceiling_clip_z_m = w.office->height_m;
  wc.cap_ceiling = true;
  return World(generateOffice(*w.office).mesh, wc);
}

std::filesystem::path benchmarkWorldFile(const BenchmarkWorld& w, const std::filesystem::path& out_dir) {
  std::filesystem::path file = w.mesh;
  if (w.office) {
    file = out_dir / "worlds" / (w.name + ".ply");
    std::filesystem::create_directories(file.parent_path());
    io::writePlyMesh(file, generateOffice(*w.office).mesh);
  }
  return std::filesystem::absolute(file).lexically_normal();
}

}  // namespace vdbmap::sim
