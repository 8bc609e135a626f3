// Scenes, cameras and poses shared by the TSDF tests (analytic, seeded).
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/mesh.hpp"
#include "vdbmap/testing/analytic_scene.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <string>
#include <limits>
#include <random>
#include <vector>

namespace vdbmap::test {

using testing::AnalyticScene;

/// A pinhole camera: width x height pixels, focal length f (pixels) on both axes, principal point
/// (cx, cy).
inline CameraIntrinsics pinholeCamera(int width, int height, double f, double cx, double cy) {
  CameraIntrinsics K;
  K.width = width;
  K.height = height;
  K.fx = K.fy = f;
  K.cx = cx;
  K.cy = cy;
  return K;
}

/// A small camera keeps the tests fast; the geometry is the same as FUEL's camera, scaled.
inline CameraIntrinsics smallCamera() { return pinholeCamera(160, 120, 96.8, 79.5, 59.5); }

inline PointCloud render(const AnalyticScene& scene, const Pose3d& T_W_S, const CameraIntrinsics& K = smallCamera(),
                         double max_range_m = 5.0) {
  return backProject(scene.renderDepth(K, T_W_S, max_range_m), K);
}

/// Random poses inside the demo room, looking around, with a fixed seed.
inline std::vector<Pose3d> randomPoses(int n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(-2.5, 2.5), y(-1.5, 1.5), z(0.8, 2.0), yaw(-M_PI, M_PI), pitch(-0.3, 0.5);
  std::vector<Pose3d> poses;
  for (int i = 0; i < n; ++i) poses.push_back(lookingPose({x(rng), y(rng), z(rng)}, yaw(rng), pitch(rng)));
  return poses;
}

/// Depth images of the demo room with seeded depth noise, an invalid pixel and some pixels beyond
/// 5 m (the room's far corners), seen with smallCamera().
inline std::vector<DepthImage> randomDepthImages(const std::vector<Pose3d>& poses, std::uint32_t seed) {
  const AnalyticScene scene = AnalyticScene::demoRoom();
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 0.01f);
  std::vector<DepthImage> images;
  for (const Pose3d& T : poses) {
    DepthImage depth = scene.renderDepth(smallCamera(), T, 10.0);
    for (float& d : depth.depth_m)
      if (d > 0.0f) d += noise(rng);
    depth.at(3, 4) = std::numeric_limits<float>::quiet_NaN();
    images.push_back(std::move(depth));
  }
  return images;
}

/// The same frames as points in the sensor frame.
inline std::vector<PointCloud> randomFrames(const std::vector<Pose3d>& poses, std::uint32_t seed) {
  std::vector<PointCloud> frames;
  for (const DepthImage& depth : randomDepthImages(poses, seed)) frames.push_back(backProject(depth, smallCamera()));
  return frames;
}

inline TsdfConfig config(double voxel_size_m, Weighting weighting = Weighting::InverseSquare) {
  TsdfConfig c;
  c.voxel_size_m = voxel_size_m;
  c.weighting = weighting;
  return c;
}

/// Root mean square distance of the mesh's vertices to the analytic surfaces.
/// Whether two volumes hold the same hit count in every voxel.
inline bool sameHitCounts(const TsdfVolume& x, const TsdfVolume& y) {
  std::size_t voxels = 0;
  for (auto it = x.hitCountGrid()->cbeginValueOn(); it; ++it, ++voxels)
    if (y.hitCountGrid()->tree().getValue(it.getCoord()) != *it) return false;
  return voxels == y.hitCountGrid()->activeVoxelCount();
}

inline double meshRmse(const TriangleMesh& mesh, const AnalyticScene& scene) {
  REQUIRE(mesh.vertices.size() > 100);
  double sum = 0.0;
  for (const Vec3f& v : mesh.vertices) {
    const double d = scene.distance(v.cast<double>());
    sum += d * d;
  }
  return std::sqrt(sum / double(mesh.vertices.size()));
}

/// Writes the OpenVDB file `from` to `to` (the same path is fine) with its grids named in
/// `grid_names` (all when empty) and its file metadata after edit(meta): old or damaged maps and
/// companions for the loading tests.
template <typename Edit>
void rewriteVdbFile(const std::filesystem::path& from, const std::filesystem::path& to,
                    const std::vector<std::string>& grid_names, Edit&& edit) {
  initializeOpenVdb();
  openvdb::GridPtrVec grids;
  openvdb::MetaMap::Ptr meta;
  {
    openvdb::io::File file(from.string());
    // Read whole: a delay-loaded grid reads its leaves when it is written, after this file and
    // the grids it shared its stream with are gone (AddressSanitizer: heap-use-after-free).
    file.open(/*delayLoad=*/false);
    meta = file.getMetadata();
    if (grid_names.empty()) {
      const openvdb::GridPtrVecPtr all = file.getGrids();
      grids.assign(all->begin(), all->end());
    } else {
      for (const std::string& name : grid_names) grids.push_back(file.readGrid(name));
    }
  }
  edit(*meta);
  openvdb::io::File(to.string()).write(grids, *meta);
}

}  // namespace vdbmap::test
