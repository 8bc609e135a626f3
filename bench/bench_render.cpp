// Depth rendering speed of the simulator's World (sim/world.hpp) on a mesh: world construction
// time and 640x480 frame time (FUEL's camera, 5 m) by rasterization (DepthCamera::render) and, on
// a quarter of the poses, by ray casting (renderByRaycast, also compared pixel by pixel), from
// seeded random poses at 1 m height that keep 0.5 m from every surface. Prints one JSON line.
//
//   cmake --build build --target vdbmap_bench_render
//   build/bin/vdbmap_bench_render [mesh.ply] [frames] [threads]
// (default mesh: ../shared/data/aws_small_house_world/small_house_visual_mesh.ply)
#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/camera.hpp"
#include "vdbmap/sim/depth_camera.hpp"
#include "vdbmap/sim/trajectory.hpp"
#include "vdbmap/sim/world.hpp"

#include <tbb/global_control.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <random>

using namespace vdbmap;
using Clock = std::chrono::steady_clock;

int main(int argc, char** argv) {
  const std::string mesh_file =
      argc > 1 ? argv[1] : VDBMAP_SOURCE_DIR "/../shared/data/aws_small_house_world/small_house_visual_mesh.ply";
  const int frames = argc > 2 ? std::atoi(argv[2]) : 40;
  const int threads = argc > 3 ? std::atoi(argv[3]) : 0;
  std::unique_ptr<tbb::global_control> limit;
  if (threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
  const TriangleMesh mesh = io::readTriangleMesh(mesh_file);
  const sim::DepthCamera camera;
  {
    const sim::WorldConfig config;
    const auto b0 = Clock::now();
    const sim::World world(mesh, config);
    const double build_s = std::chrono::duration<double>(Clock::now() - b0).count();
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> ux(world.bounds().min().x(), world.bounds().max().x());
    std::uniform_real_distribution<double> uy(world.bounds().min().y(), world.bounds().max().y());
    std::uniform_real_distribution<double> uyaw(-M_PI, M_PI);
    std::vector<double> ms, ms_ray;
    double max_diff = 0.0;
    std::size_t valid = 0;
    while (int(ms.size()) < frames) {
      const Vec3d p(ux(rng), uy(rng), 1.0);
      if (!world.isClear(p, 0.5)) continue;
      const Pose3d T_W_S = vdbmap::lookingPose(p, uyaw(rng));
      const auto t0 = Clock::now();
      const DepthImage depth = camera.render(world, T_W_S);
      ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      if (int(ms_ray.size()) < frames / 4 + 1) {
        const auto t1 = Clock::now();
        const DepthImage ray = camera.renderByRaycast(world, T_W_S);
        ms_ray.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t1).count());
        std::size_t differ = 0;
        for (std::size_t i = 0; i < ray.depth_m.size(); ++i)
          if (std::abs(ray.depth_m[i] - depth.depth_m[i]) > 1e-4) ++differ;
        max_diff = std::max(max_diff, double(differ) / double(ray.depth_m.size()));
      }
      valid += std::size_t(std::count_if(depth.depth_m.begin(), depth.depth_m.end(), [](float z) { return z > 0; }));
    }
    std::sort(ms.begin(), ms.end());
    std::sort(ms_ray.begin(), ms_ray.end());
    std::cout << nlohmann::json{{"mesh", mesh_file},
                                {"triangles", world.stats().triangles},
                                {"bvh_nodes", world.stats().bvh_nodes},
                                {"bvh_depth", world.stats().bvh_depth},
                                {"build_s", build_s},
                                {"frames", frames},
                                {"threads", threads},
                                {"ms_per_frame_median", ms[ms.size() / 2]},
                                {"ms_per_frame_max", ms.back()},
                                {"raycast_ms_per_frame_median", ms_ray[ms_ray.size() / 2]},
                                {"raycast_max_fraction_of_pixels_differing_by_0.1mm", max_diff},
                                {"valid_pixel_fraction", double(valid) / (double(frames) * 640 * 480)}}
                     .dump()
              << std::endl;
  }
  return 0;
}
