// Projective integration of depth images (RayMode::Projective): the same invariants as the ray
// integrator (exact reversibility, thread independence, accuracy, voxel states), and agreement
// with the rays on what is known and where the surface is.
#include "tsdf_test_helpers.hpp"
#include "common/shared_data.hpp"
#include "vdbmap/io/frame_source.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace vdbmap;
using namespace vdbmap::test;

namespace {
IntegratorConfig projective(int threads = 0) {
  IntegratorConfig in;
  in.ray_mode = RayMode::Projective;
  in.threads = threads;
  return in;
}

}  // namespace

TEST_CASE("projective: integrating then de-integrating images in another order restores the empty map",
          "[tsdf][projective][reversibility]") {
  for (const Weighting weighting : {Weighting::Constant, Weighting::InverseSquare}) {
    INFO("weighting " << toString(weighting));
    IntegratorConfig in = projective();
    in.max_range_m = 4.0;  // the room's far corners are beyond: they only carve
    TsdfVolume volume(config(0.1, weighting), in);
    const auto poses = randomPoses(6, 7);
    const auto images = randomDepthImages(poses, 11);
    std::size_t beyond = 0;
    for (std::size_t i = 0; i < images.size(); ++i)
      beyond += volume.integrate(i, images[i], smallCamera(), poses[i]).points_beyond_range;
    REQUIRE(beyond > 0);
    REQUIRE(volume.activeVoxelCount() > 10000);
    for (const std::size_t i : {3, 0, 5, 1, 4, 2}) volume.deintegrate(i, images[i], smallCamera(), poses[i]);
    CHECK(volume.activeVoxelCount() == 0);
    CHECK(volume.weightSumGrid()->tree().leafCount() == 0);
    CHECK(volume.exactlyEquals(TsdfVolume(config(0.1, weighting), in)));
  }
}

TEST_CASE("projective: integrating A, B, C and de-integrating B equals integrating A and C",
          "[tsdf][projective][reversibility]") {
  const auto poses = randomPoses(3, 21);
  const auto images = randomDepthImages(poses, 22);
  TsdfVolume abc(config(0.05), projective()), ac(config(0.05), projective());
  for (int i : {0, 1, 2}) abc.integrate(i, images[i], smallCamera(), poses[i]);
  abc.deintegrate(1, images[1], smallCamera(), poses[1]);
  for (int i : {0, 2}) ac.integrate(i, images[i], smallCamera(), poses[i]);
  CHECK(abc.exactlyEquals(ac));
}

TEST_CASE("projective: the map does not depend on the thread count or the frame order", "[tsdf][projective][determinism]") {
  const auto poses = randomPoses(4, 31);
  const auto images = randomDepthImages(poses, 32);
  TsdfVolume a(config(0.05), projective(1)), b(config(0.05), projective(2));
  for (int i : {0, 1, 2, 3}) a.integrate(i, images[i], smallCamera(), poses[i]);
  for (int i : {3, 1, 0, 2}) b.integrate(i, images[i], smallCamera(), poses[i]);
  CHECK(a.exactlyEquals(b));
}

TEST_CASE("projective: de-integrating with another image or pose is refused and changes nothing",
          "[tsdf][projective][bad-input]") {
  const auto poses = randomPoses(2, 5);
  const auto images = randomDepthImages(poses, 6);
  TsdfVolume volume(config(0.1), projective());
  volume.integrate(0, images[0], smallCamera(), poses[0]);
  const TsdfVolume before = volume;
  CHECK_THROWS_WITH(volume.deintegrate(0, images[1], smallCamera(), poses[0]),
                    Catch::Contains("depth image, intrinsics or pose differ"));
  CHECK_THROWS_AS(volume.deintegrate(0, images[0], smallCamera(), poses[1]), FrameError);
  CHECK_THROWS_AS(volume.integrate(1, DepthImage(10, 10), smallCamera(), poses[0]), std::invalid_argument);
  CHECK(volume.exactlyEquals(before));
}

TEST_CASE("projective: the zero crossing lies on analytic surfaces within a quarter voxel RMSE",
          "[tsdf][projective][accuracy]") {
  const double voxel = 0.05;
  constexpr double kMaxRmseVox = 0.25;
  AnalyticScene plane, sphere, room;
  plane.addPlane({0, 0, 0}, {0.3, 0.2, 1.0});
  sphere.addSphere({0, 0, 1}, 0.8);
  room.addRoom({-2, -1.5, 0}, {2, 1.5, 2.5});
  std::vector<Pose3d> plane_poses, sphere_poses, room_poses;
  for (int i = 0; i < 5; ++i) plane_poses.push_back(lookingPose({0.3 * i - 0.6, 0.2 * i - 0.4, 2.0}, 0.4 * i, 1.2));
  for (int i = 0; i < 8; ++i) {
    const double a = 2 * M_PI * i / 8;
    sphere_poses.push_back(lookingPose({2.5 * std::cos(a), 2.5 * std::sin(a), 1.0}, a + M_PI));
    room_poses.push_back(lookingPose({0.2, -0.1, 1.3}, 2 * M_PI * i / 8, 0.3 * std::sin(i)));
  }
  const std::vector<std::tuple<const char*, const AnalyticScene*, const std::vector<Pose3d>*>> cases = {
      {"tilted plane", &plane, &plane_poses}, {"sphere", &sphere, &sphere_poses}, {"box room", &room, &room_poses}};
  for (const auto& [name, scene, poses] : cases) {
    INFO(name);
    TsdfVolume volume(config(voxel), projective());
    for (std::size_t i = 0; i < poses->size(); ++i)
      volume.integrate(i, scene->renderDepth(smallCamera(), (*poses)[i], 5.0), smallCamera(), (*poses)[i]);
    CHECK(meshRmse(extractMesh(volume), *scene) < kMaxRmseVox * voxel);
  }
}

TEST_CASE("projective: free in front of a wall, occupied on it, unknown beyond and unseen; far pixels only carve",
          "[tsdf][projective][states]") {
  const double voxel = 0.1;
  AnalyticScene wall;
  wall.addPlane({3.0, 0, 0}, {-1, 0, 0});
  const Pose3d T = lookingPose({0, 0, 1}, 0.0);
  TsdfVolume volume(config(voxel), projective());
  volume.integrate(0, wall.renderDepth(smallCamera(), T, 10.0), smallCamera(), T);
  CHECK(volume.stateAt({1.0, 0, 1}) == VoxelState::Free);
  CHECK(volume.stateAt({2.7, 0, 1}) == VoxelState::Free);
  CHECK(volume.stateAt({3.0, 0, 1}) == VoxelState::Occupied);
  CHECK(volume.stateAt({3.2, 0, 1}) == VoxelState::Occupied);
  CHECK(volume.stateAt({3.6, 0, 1}) == VoxelState::Unknown);
  CHECK(volume.stateAt({-1.0, 0, 1}) == VoxelState::Unknown);
  CHECK(volume.stateAt({1.0, 0, 5}) == VoxelState::Unknown);
  CHECK(std::abs(volume.sampleAt({3.0, 0, 1}).tsdf_m) < 0.25 * voxel);

  AnalyticScene far_wall;
  far_wall.addPlane({8.0, 0, 0}, {-1, 0, 0});
  IntegratorConfig in = projective();
  in.max_range_m = 5.0;
  TsdfVolume carve(config(voxel), in);
  const IntegrationStats stats = carve.integrate(0, far_wall.renderDepth(smallCamera(), T, 20.0), smallCamera(), T);
  CHECK(stats.points_beyond_range == stats.points_total);
  CHECK(carve.stateAt({3.0, 0, 1}) == VoxelState::Free);
  CHECK(carve.stateAt({4.6, 0, 1}) == VoxelState::Free);  // carving stops at max range - truncation
  CHECK(carve.stateAt({5.5, 0, 1}) == VoxelState::Unknown);
  CHECK(carve.stateAt({8.0, 0, 1}) == VoxelState::Unknown);
  CHECK(extractMesh(carve).triangles.empty());
}

TEST_CASE("projective and ray integration agree on what is known and on the surface", "[tsdf][projective]") {
  // Same frames both ways: the known voxel sets overlap almost entirely (they differ only at the
  // frustum's and the band's voxel-wide fringes), and so do the states of the common voxels.
  const auto poses = randomPoses(4, 61);
  const auto images = randomDepthImages(poses, 62);
  IntegratorConfig merged;
  merged.ray_mode = RayMode::Merged;
  TsdfVolume by_pixel(config(0.1), projective()), by_ray(config(0.1), merged);
  for (std::size_t i = 0; i < images.size(); ++i) {
    by_pixel.integrate(i, images[i], smallCamera(), poses[i]);
    by_ray.integrate(i, backProject(images[i], smallCamera()), poses[i]);
  }
  const auto pixel_tsdf = by_pixel.tsdfGrid(), ray_tsdf = by_ray.tsdfGrid();
  std::size_t common = 0, same_state = 0;
  for (auto it = pixel_tsdf->cbeginValueOn(); it; ++it) {
    if (!ray_tsdf->tree().isValueOn(it.getCoord())) continue;
    ++common;
    same_state += by_pixel.state(it.getCoord()) == by_ray.state(it.getCoord()) ? 1 : 0;
  }
  const double known_pixel = double(pixel_tsdf->activeVoxelCount()), known_ray = double(ray_tsdf->activeVoxelCount());
  INFO("known: projective " << known_pixel << ", rays " << known_ray << ", common " << common);
  CHECK(double(common) / std::max(known_pixel, known_ray) > 0.9);
  CHECK(double(same_state) / double(common) > 0.98);
}

TEST_CASE("reintegrate moves a frame exactly as de-integrating and integrating it would", "[tsdf][reintegration]") {
  const auto poses = randomPoses(3, 71);
  const auto images = randomDepthImages(poses, 72);
  // A loop closure's large correction, and a small one that leaves most end points in their voxel.
  const Pose3d large = Eigen::Translation3d(0.12, -0.07, 0.03) * poses[1] * Eigen::AngleAxisd(0.05, Vec3d::UnitY());
  const Pose3d small = Eigen::Translation3d(0.004, -0.002, 0.001) * poses[1] * Eigen::AngleAxisd(0.002, Vec3d::UnitY());
  IntegratorConfig merged;
  merged.ray_mode = RayMode::Merged;
  for (const auto& [in, moved] :
       {std::pair{projective(), large}, std::pair{merged, large}, std::pair{projective(), small}}) {
    INFO("ray mode " << toString(in.ray_mode) << ", moved by " << (moved.translation() - poses[1].translation()).norm()
                     << " m");
    TsdfVolume one_pass(config(0.05), in), two_steps(config(0.05), in), fresh(config(0.05), in);
    for (int i : {0, 1, 2}) {
      one_pass.integrate(i, images[i], smallCamera(), poses[i]);
      two_steps.integrate(i, images[i], smallCamera(), poses[i]);
      fresh.integrate(i, images[i], smallCamera(), i == 1 ? moved : poses[i]);
    }
    const IntegrationStats stats = one_pass.reintegrate(1, images[1], smallCamera(), poses[1], moved);
    CHECK(stats.voxel_updates > 0);
    two_steps.deintegrate(1, images[1], smallCamera(), poses[1]);
    two_steps.integrate(1, images[1], smallCamera(), moved);
    CHECK(one_pass.exactlyEquals(two_steps));
    CHECK(one_pass.exactlyEquals(fresh));
    CHECK(one_pass.integratedPoses().at(1).isApprox(moved));
    // The frame now sits at `moved`: moving it from its old pose again is refused, changing nothing.
    CHECK_THROWS_AS(one_pass.reintegrate(1, images[1], smallCamera(), poses[1], moved), FrameError);
    CHECK(one_pass.exactlyEquals(fresh));
    // Points: the same contract.
    const PointCloud points = backProject(images[0], smallCamera());
    TsdfVolume a(config(0.05), merged), b(config(0.05), merged);
    a.integrate(0, points, poses[0]);
    a.reintegrate(0, points, poses[0], moved);
    b.integrate(0, points, moved);
    CHECK(a.exactlyEquals(b));
  }
}

TEST_CASE("hits counted from a depth image's pixels equal those of its back-projected cloud, at range limits",
          "[tsdf][hits]") {
  // The pixel path counts several pixels at a time; the cloud path one point at a time. A narrow
  // camera of many pixels puts 3 million end points into a small frustum, enough that some lie
  // within a float rounding of a voxel face (a point that missed the rounding would count in the
  // neighbouring voxel there). An odd width leaves each row a last pixel of its own, and min/max
  // range (1 m, 4 m) cut rows between the pixels of one pair. Invalid pixels (NaN, infinite,
  // negative, zero) sit in both lanes of a pair.
  const CameraIntrinsics K = pinholeCamera(641, 481, 2000.0, 320.3, 240.7);
  const auto poses = randomPoses(10, 71);
  const AnalyticScene scene = AnalyticScene::demoRoom();
  std::vector<DepthImage> images;
  for (const Pose3d& T : poses) {
    DepthImage depth = scene.renderDepth(K, T, 10.0);
    depth.at(10, 5) = std::numeric_limits<float>::quiet_NaN();
    depth.at(11, 5) = std::numeric_limits<float>::infinity();
    depth.at(20, 7) = -1.0f;
    depth.at(21, 7) = 0.0f;
    depth.at(160, 8) = std::numeric_limits<float>::quiet_NaN();
    images.push_back(std::move(depth));
  }
  IntegratorConfig from_pixels = projective(), from_cloud;
  from_cloud.ray_mode = RayMode::Merged;
  for (IntegratorConfig* in : {&from_pixels, &from_cloud}) {
    in->min_range_m = 1.0;
    in->max_range_m = 4.0;
  }
  TsdfVolume a(config(0.02), from_pixels), b(config(0.02), from_cloud);
  for (std::size_t i = 0; i < images.size(); ++i) {
    a.integrate(i, images[i], K, poses[i]);
    b.integrate(i, backProject(images[i], K), poses[i]);
  }
  REQUIRE(a.hitCountGrid()->activeVoxelCount() > 10000);
  CHECK(sameHitCounts(a, b));
  // A correction of a few millimetres (most points stay in their voxel) and one of centimetres.
  for (const double scale : {0.1, 3.0}) {
    const Pose3d correction = Eigen::Translation3d(0.011 * scale, -0.007 * scale, 0.003 * scale) *
                              Eigen::AngleAxisd(0.004 * scale, Vec3d::UnitZ()) * Pose3d::Identity();
    for (std::size_t i = 0; i < images.size(); ++i) {
      const Pose3d moved = correction * poses[i];
      a.reintegrate(i, images[i], K, poses[i], moved);
      b.reintegrate(i, backProject(images[i], K), poses[i], moved);
      a.deintegrate(i, images[i], K, moved);
      b.deintegrate(i, backProject(images[i], K), moved);
      a.integrate(i, images[i], K, poses[i]);
      b.integrate(i, backProject(images[i], K), poses[i]);
    }
    CHECK(sameHitCounts(a, b));
  }
  for (std::size_t i = 0; i < images.size(); ++i) a.deintegrate(i, images[i], K, poses[i]);
  CHECK(a.hitCountGrid()->activeVoxelCount() == 0);
}

TEST_CASE("hits counted from a depth image's pixels equal those of its back-projected cloud, on real frames",
          "[tsdf][hits][shared]") {
  // The projective path counts hits from the pixels without making the cloud; every end point
  // must fall in the voxel the cloud's point falls in, or the counts differ by one at voxel
  // boundaries. 20 real Kinect frames (6 million end points) showed such cases when the float rounding
  // of a point computed from its pixel was lost (see keptFloat).
  const auto source = io::openDataset(requireSharedData("7scenes_redkitchen_tsdf_fusion_python"));
  IntegratorConfig from_pixels, from_cloud;
  from_cloud.ray_mode = RayMode::Merged;  // points: hits from the cloud
  TsdfVolume a(config(0.05), from_pixels), b(config(0.05), from_cloud);
  std::vector<io::Frame> frames;
  for (std::size_t i = 0; i < 500; i += 25) frames.push_back(source->load(i));
  for (const io::Frame& f : frames) {
    a.integrate(f.index, f.data.depthImage(), f.data.intrinsics(), f.T_W_S);
    b.integrate(f.index, backProject(f.data.depthImage(), f.data.intrinsics()), f.T_W_S);
  }
  REQUIRE(a.hitCountGrid()->activeVoxelCount() > 10000);
  CHECK(sameHitCounts(a, b));
  // Moving every frame by a loop closure's correction moves the same hits.
  const Pose3d correction =
      Eigen::Translation3d(0.031, -0.017, 0.009) * Eigen::AngleAxisd(0.013, Vec3d::UnitZ()) * Pose3d::Identity();
  for (const io::Frame& f : frames) {
    a.reintegrate(f.index, f.data.depthImage(), f.data.intrinsics(), f.T_W_S, correction * f.T_W_S);
    b.reintegrate(f.index, backProject(f.data.depthImage(), f.data.intrinsics()), f.T_W_S, correction * f.T_W_S);
  }
  CHECK(sameHitCounts(a, b));
}
