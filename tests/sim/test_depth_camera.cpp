// The simulated depth camera (sim/depth_camera.hpp): exact depth by rasterization, checked
// against analytic geometry and against one ray per pixel.
#include <catch2/catch.hpp>

#include "sim/sim_test_helpers.hpp"
#include "vdbmap/testing/analytic_scene.hpp"
#include "vdbmap/sim/depth_camera.hpp"

#include <algorithm>
#include <cmath>

using namespace vdbmap;
using namespace vdbmap::sim;
using vdbmap::testing::AnalyticScene;

namespace {
/// A square plane of side 2 * half through `centre` with unit normal `n`, as 2 triangles.
TriangleMesh planeMesh(const Vec3d& centre, const Vec3d& n, double half) {
  const Vec3d u = n.unitOrthogonal(), v = n.cross(u);
  TriangleMesh m;
  for (const auto& [a, b] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}})
    m.vertices.push_back((centre + half * (a * u + b * v)).cast<float>());
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}
}  // namespace

TEST_CASE("the camera renders an analytic plane's depth to within 1 mm, with no hole on the diagonal",
          "[sim][camera]") {
  // A tilted plane 2.5 m ahead, much larger than the view; the camera is rotated and pitched.
  const Vec3d centre(3.0, 0.5, 1.0), normal = Vec3d(-1.0, 0.3, 0.2).normalized();
  const World world(planeMesh(centre, normal, 20.0));
  const Pose3d T_W_S = lookingPose(Vec3d(0.5, 0.2, 1.1), 0.15, 0.1);
  const DepthCamera camera;
  const DepthImage depth = camera.render(world, T_W_S);
  AnalyticScene analytic;
  analytic.addPlane(centre, normal);
  const DepthImage exact = analytic.renderDepth(camera.intrinsics(), T_W_S, 100.0);
  double worst = 0.0;
  std::size_t missing = 0;
  for (std::size_t i = 0; i < depth.depth_m.size(); ++i) {
    if (!(depth.depth_m[i] > 0))
      ++missing;
    else
      worst = std::max(worst, double(std::abs(depth.depth_m[i] - exact.depth_m[i])));
  }
  CHECK(missing == 0);  // every pixel sees the plane, including those on the shared edge
  CHECK(worst < 1e-3);
  CHECK(worst < 1e-5);  // in fact exact to float rounding
}

TEST_CASE("rasterized depth equals one ray per pixel on the house world", "[sim][camera]") {
  const World world = World::load(test::houseMesh());
  DepthCameraConfig config;  // a quarter-size image keeps the ray casting quick
  config.intrinsics = {160, 120, 387.229 / 4, 387.229 / 4, 80.0, 60.0};
  const DepthCamera camera(config);
  std::size_t pixels = 0, differ = 0, valid = 0;
  for (const auto& [p, yaw] : {std::pair{Vec3d(0.0, 0.0, 1.0), 0.3},
                               {Vec3d(-5.0, 2.0, 1.2), 2.0},
                               {Vec3d(4.0, -3.0, 1.5), -1.4},
                               {Vec3d(6.0, 2.0, 0.8), 3.0}}) {
    const Pose3d T_W_S = lookingPose(p, yaw, 0.2);
    const DepthImage a = camera.render(world, T_W_S), b = camera.renderByRaycast(world, T_W_S);
    for (std::size_t i = 0; i < a.depth_m.size(); ++i) {
      ++pixels;
      valid += a.depth_m[i] > 0;
      // Pixels whose centre lies exactly on an edge between triangles at different depths may go
      // either way; anything else must agree to float rounding.
      if (std::abs(a.depth_m[i] - b.depth_m[i]) > 1e-4f) ++differ;
    }
  }
  CHECK(valid > pixels / 2);
  CHECK(double(differ) / double(pixels) < 1e-3);
}

TEST_CASE("the camera's range limits and seeded depth noise", "[sim][camera]") {
  const World world(test::roomWithBox());
  const Pose3d T_W_S = lookingPose(Vec3d(-2.5, 0.3, 1.0), 0.0);  // facing +x: the far wall at 5.5 m
  DepthCameraConfig config;
  config.intrinsics = {64, 48, 40.0, 40.0, 32.0, 24.0};
  const DepthImage clean = DepthCamera(config).render(world, T_W_S);
  // The far wall is beyond 5 m where no box is in front: those pixels are invalid, the box's valid.
  CHECK(clean.at(32, 24) == 0.0f);
  CHECK(std::count_if(clean.depth_m.begin(), clean.depth_m.end(), [](float z) { return z > 0; }) > 100);
  config.far_clip_m = 10.0;
  const DepthImage far = DepthCamera(config).render(world, T_W_S);
  CHECK(far.at(32, 24) == Approx(5.5).margin(1e-4));

  config.noise_sigma_m = 0.01;
  config.noise_seed = 3;
  const DepthImage n1 = DepthCamera(config).render(world, T_W_S, 9), n2 = DepthCamera(config).render(world, T_W_S, 9);
  const DepthImage n3 = DepthCamera(config).render(world, T_W_S, 10);
  CHECK(n1.depth_m == n2.depth_m);  // same seed and frame: the same image
  CHECK(n1.depth_m != n3.depth_m);  // another frame: other noise
  double sum = 0, sum2 = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < far.depth_m.size(); ++i)
    if (far.depth_m[i] > 0 && n1.depth_m[i] > 0) {
      const double e = double(n1.depth_m[i]) - double(far.depth_m[i]);
      sum += e, sum2 += e * e, ++n;
    }
  REQUIRE(n > 1000);
  // Mean within 5 standard errors of 0; standard deviation within 10 % of 1 cm.
  CHECK(std::abs(sum / double(n)) < 5 * 0.01 / std::sqrt(double(n)));
  CHECK(std::sqrt(sum2 / double(n)) == Approx(0.01).epsilon(0.1));

  DepthCameraConfig bad;
  bad.far_clip_m = 1.0;
  CHECK_THROWS_WITH(bad.validate(), Catch::Contains("far_clip_m"));
}
