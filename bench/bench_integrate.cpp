// Integration and de-integration speed on synthetic 640x480 depth frames (fx = fy = 387.229,
// range 5 m) in a 20 x 14 x 3 m room, at 0.05 m and 0.1 m voxels, 1 and 2 threads, projective
// (depth images), merged and per-ray (points) modes. Prints one JSON line per configuration.
//
//   cmake --build build --target vdbmap_bench_integrate && build/bin/vdbmap_bench_integrate [frames] [projective|merged|per_ray]
#include "vdbmap/camera.hpp"
#include "vdbmap/testing/analytic_scene.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <string>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <iostream>

using namespace vdbmap;

namespace {
testing::AnalyticScene benchRoom() {
  testing::AnalyticScene s;
  s.addRoom({-10, -7, 0}, {10, 7, 3})
      .addBox({-6, -4, 0}, {-4, -2, 2})
      .addBox({2, 3, 0}, {5, 4, 1.2})
      .addBox({-1, -6, 0}, {1, -5, 2.5})
      .addSphere({4, -3, 1.2}, 0.9)
      .addSphere({-3, 4, 0.8}, 0.6)
      .addBox({6, -1, 0.7}, {8, 1, 0.8});
  return s;
}

/// CPU time of the whole process (all threads) in milliseconds: on a machine shared with other
/// work, CPU time per frame of a 1-thread run is a steadier figure than wall time.
double processCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return 1e3 * double(ts.tv_sec) + 1e-6 * double(ts.tv_nsec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}
}  // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 40;
  const std::string only_mode = argc > 2 ? argv[2] : "";  // "projective", "merged" or "per_ray": only that one
  const testing::AnalyticScene scene = benchRoom();
  const CameraIntrinsics K;
  std::vector<Pose3d> poses;
  std::vector<PointCloud> clouds;
  std::vector<DepthImage> images;
  std::size_t points = 0;
  for (int i = 0; i < frames; ++i) {
    const double a = 2 * M_PI * i / frames;
    const Pose3d T = vdbmap::lookingPose({5.0 * std::cos(a), 3.5 * std::sin(a), 1.3}, a + M_PI / 2 + 0.3 * std::sin(3 * a), 0.1);
    poses.push_back(T);
    images.push_back(scene.renderDepth(K, T, 6.0));
    clouds.push_back(backProject(images.back(), K));
    points += clouds.back().size();
  }
  for (const RayMode mode : {RayMode::Projective, RayMode::Merged, RayMode::PerRay}) {
    if (!only_mode.empty() && only_mode != toString(mode)) continue;
    for (const double voxel : {0.05, 0.1}) {
      for (const int threads : {1, 2}) {
        TsdfConfig c;
        c.voxel_size_m = voxel;
        IntegratorConfig in;
        in.threads = threads;
        in.ray_mode = mode;
        TsdfVolume volume(c, in);
        std::vector<double> integrate_ms, deintegrate_ms, integrate_cpu_ms;
        double total_s = 0.0;
        std::size_t rays = 0, updates = 0;
        for (int i = 0; i < frames; ++i) {
          const auto t0 = std::chrono::steady_clock::now();
          const double cpu0 = processCpuMs();
          const IntegrationStats stats = mode == RayMode::Projective ? volume.integrate(i, images[i], K, poses[i])
                                                                     : volume.integrate(i, clouds[i], poses[i]);
          integrate_cpu_ms.push_back(processCpuMs() - cpu0);
          rays += stats.rays_cast;
          updates += stats.voxel_updates;
          const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
          integrate_ms.push_back(ms);
          total_s += ms / 1e3;
        }
        const std::size_t map_bytes = volume.memoryBytes();
        const std::size_t voxels = volume.activeVoxelCount();
        for (int i = frames - 1; i >= 0; --i) {
          const auto t0 = std::chrono::steady_clock::now();
          if (mode == RayMode::Projective)
            volume.deintegrate(i, images[i], K, poses[i]);
          else
            volume.deintegrate(i, clouds[i], poses[i]);
          deintegrate_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        }
        nlohmann::json j = {{"ray_mode", toString(mode)},
                            {"voxel_size_m", voxel},
                            {"threads", threads},
                            {"frames", frames},
                            {"points_per_s", double(points) / total_s},
                            {"ms_per_frame_median", median(integrate_ms)},
                            {"cpu_ms_per_frame_median", median(integrate_cpu_ms)},
                            {"deintegrate_ms_per_frame_median", median(deintegrate_ms)},
                            {"rays_per_frame", rays / std::size_t(frames)},
                            {"voxel_updates_per_frame", updates / std::size_t(frames)},
                            {"map_bytes", map_bytes},
                            {"active_voxels", voxels},
                            {"empty_after_deintegration", volume.activeVoxelCount() == 0}};
        std::cout << j.dump() << std::endl;
      }
    }
  }
  return 0;
}
