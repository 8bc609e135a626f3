// The integrate/de-integrate soak (issue #26): random frames at random poses, integrated and
// de-integrated through one map (8 held at once), which must end empty exactly with flat resident
// memory. Prints one JSON object.
//
//   cmake --build build --target vdbmap_bench_soak && build/bin/vdbmap_bench_soak [cycles] [seed]
#include "vdbmap/testing/soak.hpp"

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <iostream>

int main(int argc, char** argv) {
  vdbmap::testing::SoakParams params;
  if (argc > 1) params.cycles = std::atoi(argv[1]);
  if (argc > 2) params.seed = std::strtoull(argv[2], nullptr, 10);
  const vdbmap::testing::SoakResult r = vdbmap::testing::runIntegrateDeintegrateSoak(params);
  nlohmann::json rss = nlohmann::json::array();
  for (const auto& [cycle, kib] : r.rss_kib) rss.push_back({{"cycle", cycle}, {"rss_kib", kib}});
  const nlohmann::json j = {{"cycles", params.cycles},
                            {"seed", params.seed},
                            {"live_frames", params.live_frames},
                            {"image", std::to_string(params.width) + "x" + std::to_string(params.height)},
                            {"voxel_size_m", params.voxel_size_m},
                            {"integrations", r.integrations},
                            {"deintegrations", r.deintegrations},
                            {"depth_frames", r.depth_frames},
                            {"point_frames", r.point_frames},
                            {"max_active_voxels", r.max_active_voxels},
                            {"active_voxels_after", {r.weight_voxels_after, r.wsdf_voxels_after, r.hit_voxels_after}},
                            {"frames_after", r.frames_after},
                            {"empty_exactly", r.emptyExactly()},
                            {"map_memory_bytes_after", r.memory_bytes_after},
                            {"rss", rss},
                            {"seconds", r.seconds}};
  std::cout << j.dump(2) << "\n";
  return r.emptyExactly() ? 0 : 1;
}
