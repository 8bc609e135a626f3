// Fuzz target: keyframe stores (map.keyframes) through vdbmap::KeyframeStore::load and
// savedUnitId; every frame of a store that loads must then decode (as depth and as points)
// without an error, since re-integration and de-integration decode them long after the load.
#include "fuzz_support.hpp"

#include "vdbmap/keyframe_store.hpp"

#include <cstdio>
#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace vdbmap;
  const std::filesystem::path file = fuzz::freshScratchDir() / "map.keyframes";
  fuzz::writeFile(file, data, size);
  fuzz::expectRefusalOrSuccess([&] { KeyframeStore::savedUnitId(file); });
  fuzz::expectRefusalOrSuccess([&] {
    const KeyframeStore store = KeyframeStore::load(file);
    try {
      for (const auto& [id, keyframe] : store) {
        (void)keyframe.data.decodeFrame();
        (void)keyframe.data.decode();
      }
    } catch (const std::exception& e) {
      std::fprintf(stderr, "fuzz: a loaded keyframe store failed to decode: %s\n", e.what());
      std::abort();
    }
  });
  return 0;
}
