// `vdbmap demo`: integrates the built-in synthetic room and reports the mesh's accuracy against
// the analytic scene.
#include "command.hpp"
#include "vdbmap/timing.hpp"

#include "vdbmap/camera.hpp"
#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/mesh.hpp"
#include "vdbmap/testing/analytic_scene.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

namespace vdbmap::cli {
namespace {

struct DemoOptions {
  std::filesystem::path out_dir = "demo_out";
  double voxel_size_m = 0.05;
  int frames = 60;
  int threads = 0;
};

void runDemo(const DemoOptions& o) {
  std::filesystem::create_directories(o.out_dir);
  const testing::AnalyticScene scene = testing::AnalyticScene::demoRoom();
  const CameraIntrinsics K;  // FUEL's simulated camera: 640x480, fx = fy = 387.229
  TsdfConfig config;
  config.voxel_size_m = o.voxel_size_m;
  IntegratorConfig integrator;
  integrator.threads = o.threads;
  TsdfVolume volume(config, integrator);

  std::vector<double> ms;
  const auto poses = testing::AnalyticScene::demoTrajectory(o.frames);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const PointCloud points_S = backProject(scene.renderDepth(K, poses[i], integrator.max_range_m + 1.0), K);
    const Stopwatch watch;
    volume.integrate(i, points_S, poses[i]);
    ms.push_back(watch.ms());
  }
  std::sort(ms.begin(), ms.end());

  const TriangleMesh mesh = extractMesh(volume);
  std::vector<double> err;
  err.reserve(mesh.vertices.size());
  for (const Vec3f& v : mesh.vertices) err.push_back(scene.distance(v.cast<double>()));
  double sq = 0.0, sum = 0.0;
  for (double e : err) {
    sq += e * e;
    sum += e;
  }
  std::sort(err.begin(), err.end());
  const double n = std::max<double>(1.0, double(err.size()));

  const auto map_path = o.out_dir / "map.vdb";
  const auto mesh_path = o.out_dir / "mesh.ply";
  volume.save(map_path);
  io::writePlyMesh(mesh_path, mesh);

  std::printf("synthetic room: %zu frames of %dx%d at %.3f m voxels\n", poses.size(), K.width, K.height,
              config.voxel_size_m);
  std::printf("integration: %.1f ms/frame median, %zu known+unknown voxels, %.1f MB exact state\n",
              ms.empty() ? 0.0 : ms[ms.size() / 2], volume.activeVoxelCount(), volume.memoryBytes() / 1e6);
  std::printf("mesh: %zu vertices, %zu triangles\n", mesh.vertices.size(), mesh.triangles.size());
  std::printf("accuracy of mesh vertices vs the analytic scene: rmse %.2f mm (%.3f voxel), mean %.2f mm, median %.2f mm\n",
              1e3 * std::sqrt(sq / n), std::sqrt(sq / n) / config.voxel_size_m, 1e3 * sum / n,
              err.empty() ? 0.0 : 1e3 * err[err.size() / 2]);
  std::printf("wrote %s (+ %s) and %s\n", map_path.c_str(), TsdfVolume::exactStatePath(map_path).c_str(),
              mesh_path.c_str());
}

const Registration registration("demo", [](CLI::App& app) {
  auto opts = std::make_shared<DemoOptions>();
  CLI::App* sub = app.add_subcommand(
      "demo", "Integrate the built-in synthetic room (a box room with a sphere and boxes, seen by a simulated "
              "640x480 depth camera), write map.vdb and mesh.ply, and print the mesh's accuracy");
  sub->option_defaults()->always_capture_default();
  sub->add_option("-o,--output", opts->out_dir, "Output folder");
  sub->add_option("--voxel-size", opts->voxel_size_m, "Voxel edge in metres")->check(CLI::PositiveNumber);
  sub->add_option("--frames", opts->frames, "Frames along the camera path")->check(CLI::Range(1, 100000));
  sub->add_option("--threads", opts->threads, "Worker threads (0 = all cores)")->check(CLI::Range(0, 1024));
  sub->callback([opts] { runDemo(*opts); });
});

}  // namespace
}  // namespace vdbmap::cli
