// Fuzz target: saved maps (.vdb) through vdbmap::TsdfVolume::load and the map-file readers of
// vdbmap/map_file.hpp (inspectMapFile, readTsdfGrid).
//
// The input is map.vdb, optionally followed by the separator kExactSeparator and the bytes of its
// exact-state companion map.exact.vdb (TsdfVolume::exactStatePath), which load() reads when it
// exists: make_corpus.sh joins a map saved by vdbmap and its companion that way.
#include "fuzz_support.hpp"

#include "vdbmap/map_file.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <string_view>

namespace {
constexpr std::string_view kExactSeparator = "\n@@VDBMAP-FUZZ-EXACT@@\n";
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace vdbmap;
  static const bool initialized = [] {
    openvdb::initialize();
    return true;
  }();
  (void)initialized;
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  const std::size_t split = in.find(kExactSeparator);
  const std::filesystem::path map = fuzz::freshScratchDir() / "map.vdb";
  if (split == std::string_view::npos) {
    fuzz::writeFile(map, data, size);
  } else {
    fuzz::writeFile(map, data, split);
    const std::size_t rest = split + kExactSeparator.size();
    fuzz::writeFile(TsdfVolume::exactStatePath(map), data + rest, size - rest);
  }
  fuzz::expectRefusalOrSuccess([&] { TsdfVolume::load(map); });
  fuzz::expectRefusalOrSuccess([&] { inspectMapFile(map); });
  fuzz::expectRefusalOrSuccess([&] { readTsdfGrid(map); });
  return 0;
}
