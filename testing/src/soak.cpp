#include "vdbmap/testing/soak.hpp"

#include "vdbmap/timing.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <deque>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>

namespace vdbmap::testing {
namespace {

/// VmRSS of this process in KiB (0 where /proc is missing).
std::size_t residentKib() {
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == "VmRSS:") {
      std::size_t kib = 0;
      status >> kib;
      return kib;
    }
    status.ignore(1 << 12, '\n');
  }
  return 0;
}

struct LiveFrame {
  FrameId id = 0;
  bool depth = true;
  DepthImage image;
  PointCloud points;
  Pose3d T_W_S = Pose3d::Identity();
};

}  // namespace

void SoakParams::validate() const {
  auto require = [](bool ok, const char* field, const char* range) {
    if (!ok) throw std::invalid_argument(std::string("SoakParams.") + field + " must be " + range);
  };
  require(cycles >= 1 && cycles <= 10000000, "cycles", "in [1, 1e7]");
  require(live_frames >= 1 && live_frames <= 1000, "live_frames", "in [1, 1000]");
  require(width >= 2 && width <= 4096 && height >= 2 && height <= 4096, "width/height", "in [2, 4096]");
  require(voxel_size_m >= 0.005 && voxel_size_m <= 10.0, "voxel_size_m", "in [0.005, 10]");
  require(pose_box_m >= 0.0 && pose_box_m <= 1000.0, "pose_box_m", "in [0, 1000]");
  require(memory_samples >= 2 && memory_samples <= 1000, "memory_samples", "in [2, 1000]");
  require(threads >= 0, "threads", ">= 0");
}

SoakResult runIntegrateDeintegrateSoak(const SoakParams& p) {
  p.validate();
  const Stopwatch clock;
  TsdfConfig tsdf;
  tsdf.voxel_size_m = p.voxel_size_m;
  IntegratorConfig integrator;
  integrator.threads = p.threads;
  TsdfVolume volume(tsdf, integrator);
  CameraIntrinsics K;
  K.width = p.width;
  K.height = p.height;
  K.fx = K.fy = 0.8 * p.width;
  K.cx = 0.5 * (p.width - 1);
  K.cy = 0.5 * (p.height - 1);

  std::mt19937_64 rng(p.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0), depth_m(0.2, 6.0), box(-p.pose_box_m, p.pose_box_m);
  std::normal_distribution<double> gauss(0.0, 1.0);
  auto randomFrame = [&](FrameId id) {
    LiveFrame f;
    f.id = id;
    f.depth = id % 2 == 0;
    Eigen::Quaterniond q(gauss(rng), gauss(rng), gauss(rng), gauss(rng));  // uniform on SO(3) once normalised
    q.normalize();
    f.T_W_S.linear() = q.toRotationMatrix();
    f.T_W_S.translation() = Vec3d(box(rng), box(rng), box(rng));
    if (f.depth) {
      f.image = DepthImage(p.width, p.height);
      for (float& d : f.image.depth_m) d = unit(rng) < 0.1 ? 0.0f : float(depth_m(rng));
    } else {
      const int n = p.width * p.height / 4;
      for (int i = 0; i < n; ++i) {
        const Vec3d dir = Vec3d(gauss(rng), gauss(rng), std::abs(gauss(rng)) + 0.5).normalized();
        f.points.push_back((dir * depth_m(rng)).cast<float>());
      }
    }
    return f;
  };

  SoakResult r;
  std::deque<LiveFrame> live;
  auto removeRandomLive = [&] {
    std::uniform_int_distribution<std::size_t> pick(0, live.size() - 1);
    const std::size_t k = pick(rng);
    const LiveFrame& f = live[k];
    if (f.depth)
      volume.deintegrate(f.id, f.image, K, f.T_W_S);
    else
      volume.deintegrate(f.id, f.points, f.T_W_S);
    ++r.deintegrations;
    live.erase(live.begin() + std::ptrdiff_t(k));
  };

  const int first_sample = std::min(p.live_frames, p.cycles);
  for (int cycle = 1; cycle <= p.cycles; ++cycle) {
    LiveFrame f = randomFrame(FrameId(cycle));
    if (f.depth) {
      volume.integrate(f.id, f.image, K, f.T_W_S);
      ++r.depth_frames;
    } else {
      volume.integrate(f.id, f.points, f.T_W_S);
      ++r.point_frames;
    }
    ++r.integrations;
    live.push_back(std::move(f));
    r.max_active_voxels = std::max(r.max_active_voxels, volume.activeVoxelCount());
    if (int(live.size()) > p.live_frames) removeRandomLive();
    const int samples_done = int(r.rss_kib.size());
    const int next_at = first_sample + int(std::llround(double(p.cycles - first_sample) * samples_done /
                                                        double(p.memory_samples - 1)));
    if (samples_done < p.memory_samples && cycle >= next_at) r.rss_kib.emplace_back(cycle, residentKib());
  }
  while (!live.empty()) removeRandomLive();

  r.weight_voxels_after = volume.weightSumGrid()->activeVoxelCount();
  r.wsdf_voxels_after = volume.weightedSdfSumGrid()->activeVoxelCount();
  r.hit_voxels_after = volume.hitCountGrid()->activeVoxelCount();
  r.frames_after = volume.frameCount();
  r.memory_bytes_after = volume.memoryBytes();
  r.seconds = clock.s();
  return r;
}

}  // namespace vdbmap::testing
