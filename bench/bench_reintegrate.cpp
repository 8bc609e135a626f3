// Re-integration after one big loop-closure correction: N keyframes of 640x480 (fx = fy =
// 387.229) at 0.05 m voxels in a 20 x 14 x 3 m room, every pose corrected at once (each beyond
// the gates), processed in budgeted cycles (the default budget) until the queue is empty. Prints
// one JSON line; "reintegrated_frames" counts what was really re-integrated.
//
//   cmake --build build --target vdbmap_bench_reintegrate && build/bin/vdbmap_bench_reintegrate [frames] [voxel]
#include "vdbmap/mapper.hpp"
#include "vdbmap/testing/analytic_scene.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>

using namespace vdbmap;

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 500;
  const double voxel = argc > 2 ? std::atof(argv[2]) : 0.05;
  testing::AnalyticScene scene;
  scene.addRoom({-10, -7, 0}, {10, 7, 3}).addBox({-6, -4, 0}, {-4, -2, 2}).addSphere({4, -3, 1.2}, 0.9);
  auto K = std::make_shared<const CameraIntrinsics>();
  MapperConfig config;
  config.mode = ConsistencyMode::All;  // keep all N frames: the worst case for re-integration
  config.tsdf.voxel_size_m = voxel;
  Mapper mapper(config);
  std::map<FrameId, Pose3d> corrected;
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < frames; ++i) {
    const double a = 4 * M_PI * i / frames;
    const Pose3d T = vdbmap::lookingPose({5.0 * std::cos(a), 3.5 * std::sin(a), 1.3}, a + M_PI / 2, 0.1);
    mapper.addFrame(i, 0.1 * i, SensorFrame::depth(scene.renderDepth(*K, T, 6.0), K), T);
    // A correction that grows along the path, as after a loop closure, and moves every frame beyond
    // the gates (1 cm, 0.5 deg), so that all N are re-integrated.
    const double g = 0.5 + 0.5 * double(i) / frames;
    Pose3d C = T;
    C.translation() += Vec3d(0.05, -0.03, 0.01) * g;
    C.linear() = Eigen::AngleAxisd(0.02 * g, Vec3d::UnitZ()).toRotationMatrix() * T.linear();
    corrected[i] = C;
  }
  const double integrate_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::size_t queued = mapper.updatePoses(corrected);
  std::size_t cycles = 0;
  while (mapper.queuedFrames() > 0) {
    mapper.reintegrate(Vec3d(5.0, 0.0, 1.3));
    ++cycles;
  }
  const MapperStats& s = mapper.stats();
  std::cout << nlohmann::json{{"frames", frames},
                              {"voxel_size_m", voxel},
                              {"budget_ms", config.reintegration.budget_ms},
                              {"queued", queued},
                              {"cycles", cycles},
                              {"reintegrated_frames", s.reintegrated_frames},
                              {"reintegration_s_total", s.reintegration_ms_total / 1e3},
                              {"reintegration_ms_max_cycle", s.reintegration_ms_max_cycle},
                              {"reintegration_ms_per_frame", s.reintegration_ms_total / double(s.reintegrated_frames)},
                              {"integrate_s", integrate_s},
                              {"keyframe_store_bytes", mapper.keyframeStoreBytes()},
                              {"keyframe_bytes_per_frame", double(mapper.keyframeStoreBytes()) / frames}}
                   .dump()
            << std::endl;
  return 0;
}
