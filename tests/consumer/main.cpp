// Uses the installed vdbmap package: integrates one synthetic depth frame (a wall 2 m in front of
// the camera), checks the map's values and writes and reads back its mesh through vdbmap::io.
// Exit code 0 when every check holds.
#include <vdbmap/io/io.hpp>
#include <vdbmap/vdbmap.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>

namespace {
int failures = 0;

void check(bool ok, const char* what) {
  std::printf("%s: %s\n", ok ? "ok  " : "FAIL", what);
  if (!ok) ++failures;
}
}  // namespace

int main() {
  using namespace vdbmap;
  constexpr double kVoxel = 0.05, kWall = 2.0;
  // Quantization of the exact sums is ~1e-4 voxel; rays off the optical axis see the wall at most
  // 0.3 % farther here. A tenth of a voxel bounds both.
  constexpr double kToleranceM = 0.1 * kVoxel;

  CameraIntrinsics K;
  K.width = 64;
  K.height = 48;
  K.fx = K.fy = 50.0;
  K.cx = 31.5;
  K.cy = 23.5;
  const DepthImage depth(K.width, K.height, float(kWall));

  TsdfConfig config;
  config.voxel_size_m = kVoxel;
  config.weighting = Weighting::Constant;
  TsdfVolume volume(config);
  const IntegrationStats stats = volume.integrate(0, backProject(depth, K), Pose3d::Identity());

  std::printf("vdbmap %s: %zu rays, %zu active voxels\n", kVersion, stats.rays_cast, volume.activeVoxelCount());
  check(stats.points_total == std::size_t(K.width * K.height) && stats.points_invalid == 0, "every pixel integrated");
  const VoxelSample front = volume.sampleAt({0.0, 0.0, kWall - 2 * kVoxel});
  check(std::abs(front.tsdf_m - 2 * kVoxel) < kToleranceM, "tsdf two voxels in front of the wall is +2 voxels");
  check(volume.stateAt({0.0, 0.0, 1.0}) == VoxelState::Free, "free space between camera and wall");
  check(volume.stateAt({0.0, 0.0, kWall}) == VoxelState::Occupied, "the wall's voxel is occupied");
  check(volume.stateAt({0.0, 0.0, kWall + 1.0}) == VoxelState::Unknown, "unknown behind the wall");
  const TriangleMesh mesh = extractMesh(volume);
  const std::filesystem::path ply = std::filesystem::temp_directory_path() / "vdbmap_consumer_mesh.ply";
  io::writePlyMesh(ply, mesh);
  const TriangleMesh read_back = io::readTriangleMesh(ply);
  std::filesystem::remove(ply);
  check(!mesh.triangles.empty() && read_back.triangles.size() == mesh.triangles.size(),
        "the wall's mesh survives a PLY round trip through vdbmap::io");
  volume.deintegrate(0, backProject(depth, K), Pose3d::Identity());
  check(volume.activeVoxelCount() == 0, "de-integration empties the map");
  return failures == 0 ? 0 : 1;
}
