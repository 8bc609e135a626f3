// Writes a tiny map with vdbmap's own TsdfVolume::save, as a seed for fuzz_vdb (make_corpus.sh):
// a 0.5 m map of a 3 x 3 patch of wall 1 m in front of the sensor, plus its exact companion.
//
//   fuzz_make_vdb_seed OUT.vdb     (also writes OUT.exact.vdb)
#include "vdbmap/tsdf_volume.hpp"

#include <cstdio>
#include <exception>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s OUT.vdb\n", argv[0]);
    return 2;
  }
  try {
    // Coarse voxels and a wall close by: a few leaves, so both files stay a few KB (seeds must
    // fit the fuzzer's 64 KiB inputs).
    vdbmap::TsdfConfig config;
    config.voxel_size_m = 0.5;
    vdbmap::TsdfVolume map(config);
    vdbmap::PointCloud wall_S;
    for (int v = -1; v <= 1; ++v)
      for (int u = -1; u <= 1; ++u) wall_S.emplace_back(0.25f * float(u), 0.25f * float(v), 1.0f);
    // Every voxel in the positive octant: one root child, so one set of internal-node masks.
    vdbmap::Pose3d T_W_S = vdbmap::Pose3d::Identity();
    T_W_S.translation() = vdbmap::Vec3d(5.0, 5.0, 5.0);
    map.integrate(0, wall_S, T_W_S);
    map.save(argv[1]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_make_vdb_seed: %s\n", e.what());
    return 1;
  }
  return 0;
}
