// The TSDF core: exact reversibility, thread independence, accuracy on analytic scenes, voxel
// states, files, and bad input.
#include "tsdf_test_helpers.hpp"
#include "vdbmap/camera.hpp"
#include "vdbmap/mesh.hpp"
#include "vdbmap/testing/analytic_scene.hpp"
#include "vdbmap/testing/soak.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <tuple>
#include <random>

using namespace vdbmap;
using namespace vdbmap::test;


TEST_CASE("a short soak of random depth and point frames at random poses ends with the map empty exactly",
          "[tsdf][soak]") {
  // The benchmark runs 10,000 cycles (bench/bench_soak.cpp); 300 here, both kinds of frames.
  testing::SoakParams params;
  params.cycles = 300;
  params.seed = 26;
  const testing::SoakResult r = testing::runIntegrateDeintegrateSoak(params);
  CHECK(r.integrations == 300);
  CHECK(r.deintegrations == 300);
  CHECK(r.depth_frames == 150);
  CHECK(r.point_frames == 150);
  CHECK(r.max_active_voxels > 10000);  // the frames really wrote into the map
  CHECK(r.weight_voxels_after == 0);
  CHECK(r.wsdf_voxels_after == 0);
  CHECK(r.hit_voxels_after == 0);
  CHECK(r.frames_after == 0);
  CHECK(r.emptyExactly());
  CHECK(r.rss_kib.size() == std::size_t(params.memory_samples));
}

TEST_CASE("integrating then de-integrating frames in another order restores the empty map bit for bit",
          "[tsdf][reversibility]") {
  for (const RayMode mode : {RayMode::Merged, RayMode::PerRay}) {
    for (const Weighting weighting : {Weighting::Constant, Weighting::InverseSquare}) {
      INFO("ray mode " << toString(mode) << ", weighting " << toString(weighting));
      IntegratorConfig in;
      in.ray_mode = mode;
      in.max_range_m = 4.0;  // some points fall beyond range and only carve
      TsdfVolume volume(config(0.1, weighting), in);
      const auto poses = randomPoses(6, 7);
      const auto frames = randomFrames(poses, 11);
      for (std::size_t i = 0; i < frames.size(); ++i) volume.integrate(i, frames[i], poses[i]);
      REQUIRE(volume.activeVoxelCount() > 10000);
      for (const std::size_t i : {3, 0, 5, 1, 4, 2}) volume.deintegrate(i, frames[i], poses[i]);
      CHECK(volume.activeVoxelCount() == 0);
      CHECK(volume.weightSumGrid()->tree().leafCount() == 0);  // the tree shrank back
      CHECK(volume.hitCountGrid()->tree().leafCount() == 0);   // and so did the hit counts
      CHECK(volume.exactlyEquals(TsdfVolume(config(0.1, weighting), in)));
      CHECK(volume.frameCount() == 0);
    }
  }
}

TEST_CASE("integrating A, B, C and de-integrating B equals integrating A and C", "[tsdf][reversibility]") {
  const auto poses = randomPoses(3, 21);
  const auto frames = randomFrames(poses, 22);
  TsdfVolume abc(config(0.05)), ac(config(0.05));
  for (int i : {0, 1, 2}) abc.integrate(i, frames[i], poses[i]);
  abc.deintegrate(1, frames[1], poses[1]);
  for (int i : {0, 2}) ac.integrate(i, frames[i], poses[i]);
  CHECK(abc.activeVoxelCount() == ac.activeVoxelCount());
  CHECK(abc.exactlyEquals(ac));
}

TEST_CASE("the map does not depend on the thread count or the frame order", "[tsdf][determinism]") {
  const auto poses = randomPoses(4, 31);
  const auto frames = randomFrames(poses, 32);
  for (const RayMode mode : {RayMode::Merged, RayMode::PerRay}) {
    INFO("ray mode " << toString(mode));
    IntegratorConfig one, two;
    one.threads = 1;
    two.threads = 2;
    one.ray_mode = two.ray_mode = mode;
    TsdfVolume a(config(0.05), one), b(config(0.05), two);
    for (int i : {0, 1, 2, 3}) a.integrate(i, frames[i], poses[i]);
    for (int i : {3, 1, 0, 2}) b.integrate(i, frames[i], poses[i]);
    CHECK(a.exactlyEquals(b));
  }
}

TEST_CASE("the zero crossing lies on analytic surfaces within a quarter voxel RMSE", "[tsdf][accuracy]") {
  const double voxel = 0.05;
  constexpr double kMaxRmseVox = 0.25;
  struct Case {
    const char* name;
    AnalyticScene scene;
    std::vector<Pose3d> poses;
  };
  std::vector<Case> cases;
  {
    AnalyticScene plane;
    plane.addPlane({0, 0, 0}, {0.3, 0.2, 1.0});
    std::vector<Pose3d> poses;
    for (int i = 0; i < 5; ++i) poses.push_back(lookingPose({0.3 * i - 0.6, 0.2 * i - 0.4, 2.0}, 0.4 * i, 1.2));
    cases.push_back({"tilted plane", plane, poses});
  }
  {
    AnalyticScene sphere;
    sphere.addSphere({0, 0, 1}, 0.8);
    std::vector<Pose3d> poses;
    for (int i = 0; i < 8; ++i) {
      const double a = 2 * M_PI * i / 8;
      poses.push_back(lookingPose({2.5 * std::cos(a), 2.5 * std::sin(a), 1.0}, a + M_PI));
    }
    cases.push_back({"sphere", sphere, poses});
  }
  {
    AnalyticScene room;
    room.addRoom({-2, -1.5, 0}, {2, 1.5, 2.5});
    std::vector<Pose3d> poses;
    for (int i = 0; i < 8; ++i) poses.push_back(lookingPose({0.2, -0.1, 1.3}, 2 * M_PI * i / 8, 0.3 * std::sin(i)));
    cases.push_back({"box room", room, poses});
  }
  for (const RayMode mode : {RayMode::Merged, RayMode::PerRay}) {
    for (const Case& c : cases) {
      INFO(c.name << ", ray mode " << toString(mode));
      IntegratorConfig in;
      in.ray_mode = mode;
      TsdfVolume volume(config(voxel), in);
      for (std::size_t i = 0; i < c.poses.size(); ++i) volume.integrate(i, render(c.scene, c.poses[i]), c.poses[i]);
      const double rmse = meshRmse(extractMesh(volume), c.scene);
      CHECK(rmse < kMaxRmseVox * voxel);
    }
  }
}

TEST_CASE("voxels are free in front of a surface, occupied on and just behind it, unknown beyond and unseen",
          "[tsdf][states]") {
  const double voxel = 0.1;
  AnalyticScene wall;
  wall.addPlane({3.0, 0, 0}, {-1, 0, 0});  // a wall at x = 3 facing the camera
  TsdfVolume volume(config(voxel));
  const Pose3d T = lookingPose({0, 0, 1}, 0.0);
  volume.integrate(0, render(wall, T), T);
  CHECK(volume.stateAt({1.0, 0, 1}) == VoxelState::Free);
  CHECK(volume.stateAt({2.7, 0, 1}) == VoxelState::Free);
  CHECK(volume.stateAt({3.0, 0, 1}) == VoxelState::Occupied);
  CHECK(volume.stateAt({3.2, 0, 1}) == VoxelState::Occupied);
  CHECK(volume.stateAt({3.6, 0, 1}) == VoxelState::Unknown);   // beyond the truncation band
  CHECK(volume.stateAt({-1.0, 0, 1}) == VoxelState::Unknown);  // behind the camera
  CHECK(volume.stateAt({1.0, 0, 5}) == VoxelState::Unknown);   // outside the field of view
  const VoxelSample on = volume.sampleAt({3.0, 0, 1});
  CHECK(std::abs(on.tsdf_m) < 0.25 * voxel);
  CHECK(volume.sampleAt({2.0, 0, 1}).tsdf_m == Approx(config(voxel).truncation_m()));
}

TEST_CASE("each voxel's hit count is the number of surface end points that fell in it", "[tsdf][hits]") {
  const auto poses = randomPoses(3, 41);
  const auto images = randomDepthImages(poses, 42);  // noise, a NaN pixel, pixels beyond 5 m
  for (const RayMode mode : {RayMode::Merged, RayMode::PerRay, RayMode::Projective}) {
    INFO("ray mode " << toString(mode));
    IntegratorConfig in;
    in.ray_mode = mode;
    in.max_range_m = 5.0;
    TsdfVolume volume(config(0.1), in);
    // Brute force: every pixel's end point, kept when within [min, max] range of the sensor.
    std::map<std::tuple<int, int, int>, std::int64_t> expected;
    for (std::size_t i = 0; i < poses.size(); ++i) {
      volume.integrate(i, images[i], smallCamera(), poses[i]);
      for (const Vec3f& p : backProject(images[i], smallCamera())) {
        const double r = p.cast<double>().norm();
        if (!p.allFinite() || !(r >= in.min_range_m) || r > in.max_range_m) continue;
        const openvdb::Coord c = volume.worldToVoxel(poses[i] * p.cast<double>());
        ++expected[{c.x(), c.y(), c.z()}];
      }
    }
    REQUIRE(expected.size() > 500);
    std::size_t voxels = 0;
    for (auto it = volume.hitCountGrid()->cbeginValueOn(); it; ++it, ++voxels) {
      const openvdb::Coord c = it.getCoord();
      REQUIRE(*it == expected[{c.x(), c.y(), c.z()}]);
      CHECK(volume.sample(c).hits == *it);
    }
    CHECK(voxels == expected.size());
    // Moving a frame moves its hits: reintegrate equals integrating at the new pose.
    TsdfVolume moved = volume, direct(config(0.1), in);
    const Pose3d shifted = Eigen::Translation3d(0.13, -0.07, 0.02) * poses[1];
    moved.reintegrate(1, images[1], smallCamera(), poses[1], shifted);
    for (std::size_t i = 0; i < poses.size(); ++i)
      direct.integrate(i, images[i], smallCamera(), i == 1 ? shifted : poses[i]);
    CHECK(moved.exactlyEquals(direct));
    CHECK_FALSE(moved.exactlyEquals(volume));
  }
}

TEST_CASE("points beyond max range carve free space and add no surface", "[tsdf][range]") {
  AnalyticScene wall;
  wall.addPlane({8.0, 0, 0}, {-1, 0, 0});
  IntegratorConfig in;
  in.max_range_m = 5.0;
  TsdfVolume volume(config(0.1), in);
  const Pose3d T = lookingPose({0, 0, 1}, 0.0);
  const IntegrationStats stats = volume.integrate(0, render(wall, T, smallCamera(), 20.0), T);
  CHECK(stats.points_beyond_range == stats.points_total);
  CHECK(volume.stateAt({3.0, 0, 1}) == VoxelState::Free);
  CHECK(volume.stateAt({8.0, 0, 1}) == VoxelState::Unknown);
  CHECK(extractMesh(volume).triangles.empty());
}

TEST_CASE("save then load gives identical grids, metadata and frame registry", "[tsdf][io]") {
  const auto poses = randomPoses(2, 41);
  const auto frames = randomFrames(poses, 42);
  TsdfConfig c = config(0.08, Weighting::Constant);
  c.truncation_vox = 4.0;
  TsdfVolume volume(c);
  for (int i : {0, 1}) volume.integrate(i, frames[i], poses[i]);
  const auto dir = std::filesystem::temp_directory_path() / "vdbmap_test_save_load";
  std::filesystem::create_directories(dir);
  const auto path = dir / "map.vdb";
  volume.save(path);
  REQUIRE(std::filesystem::exists(TsdfVolume::exactStatePath(path)));

  TsdfVolume loaded = TsdfVolume::load(path);
  CHECK(loaded.hasExactState());
  CHECK(loaded.exactlyEquals(volume));
  CHECK(loaded.config().voxel_size_m == c.voxel_size_m);
  CHECK(loaded.config().truncation_vox == c.truncation_vox);
  CHECK(loaded.config().weighting == Weighting::Constant);
  CHECK(loaded.frameCount() == 2);
  // The registry survives: the loaded map de-integrates frame 1 exactly.
  loaded.deintegrate(1, frames[1], poses[1]);
  TsdfVolume only0(c);
  only0.integrate(0, frames[0], poses[0]);
  CHECK(loaded.exactlyEquals(only0));

  SECTION("OpenVDB's own reader sees float grids with our metadata") {
    openvdb::io::File file(path.string());
    file.open();
    auto tsdf = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("tsdf"));
    auto weight = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("weight"));
    REQUIRE(tsdf);
    REQUIRE(weight);
    CHECK(tsdf->activeVoxelCount() == volume.tsdfGrid()->activeVoxelCount());
    CHECK(tsdf->voxelSize()[0] == Approx(0.08));
    CHECK(file.getMetadata()->metaValue<std::string>("weighting") == "constant");
    CHECK(tsdf->metaValue<double>("truncation_vox") == 4.0);
  }
  SECTION("vdb_print lists the grids when libopenvdb-tools is installed") {
    if (std::system("command -v vdb_print > /dev/null 2>&1") != 0) {
      WARN("vdb_print not installed; skipped");
      return;
    }
    const auto out = dir / "vdb_print.txt";
    REQUIRE(std::system(("vdb_print -l " + path.string() + " > " + out.string() + " 2>&1").c_str()) == 0);
    std::ifstream in(out);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    CHECK(text.find("tsdf") != std::string::npos);
    CHECK(text.find("weight") != std::string::npos);
  }
  SECTION("a format 2 companion, from before hit counts, loads with none and de-integrates exactly") {
    const auto exact = TsdfVolume::exactStatePath(path);
    rewriteVdbFile(exact, exact, {"weight_q", "wsdf_q"}, [](openvdb::MetaMap& meta) {
      meta.removeMeta("vdbmap_format_version");
      meta.insertMeta("vdbmap_format_version", openvdb::Int32Metadata(2));
    });
    TsdfVolume old = TsdfVolume::load(path);
    CHECK(old.hasExactState());
    CHECK(old.hitCountGrid()->activeVoxelCount() == 0);
    old.deintegrate(0, frames[0], poses[0]);
    old.deintegrate(1, frames[1], poses[1]);
    CHECK(old.activeVoxelCount() == 0);  // the sums are exact
    // The hits of frames integrated before the save go negative: they read as no hits.
    REQUIRE(old.hitCountGrid()->activeVoxelCount() > 0);
    for (auto it = old.hitCountGrid()->cbeginValueOn(); it; ++it) REQUIRE(*it < 0);
  }
  SECTION("without the companion file the map loads approximately, flagged as such") {
    std::filesystem::remove(TsdfVolume::exactStatePath(path));
    TsdfVolume approx = TsdfVolume::load(path);
    CHECK_FALSE(approx.hasExactState());
    CHECK(approx.frameCount() == 0);
    CHECK(approx.tsdfGrid()->activeVoxelCount() == volume.tsdfGrid()->activeVoxelCount());
    // Values agree to float precision; a state may flip only for a voxel whose tsdf sits on the
    // occupancy threshold to within that precision.
    const double tolerance_m = 1e-3 * c.voxel_size_m;
    const double threshold_m = c.occupancy_threshold_vox * c.voxel_size_m;
    std::size_t mismatches = 0;
    const auto tsdf = volume.tsdfGrid();
    for (auto it = tsdf->cbeginValueOn(); it; ++it) {
      const VoxelSample a = approx.sample(it.getCoord()), e = volume.sample(it.getCoord());
      const bool on_threshold = std::abs(e.tsdf_m - threshold_m) <= tolerance_m;
      if ((a.state != e.state && !on_threshold) || std::abs(a.tsdf_m - e.tsdf_m) > tolerance_m) ++mismatches;
    }
    CHECK(mismatches == 0);
  }
}

TEST_CASE("loading a missing or foreign file names the file", "[tsdf][io][bad-input]") {
  CHECK_THROWS_WITH(TsdfVolume::load("/nonexistent/map.vdb"), Catch::Contains("/nonexistent/map.vdb"));
  const auto path = std::filesystem::temp_directory_path() / "vdbmap_test_foreign.vdb";
  {
    initializeOpenVdb();
    auto g = openvdb::FloatGrid::create();
    g->setName("density");
    openvdb::io::File(path.string()).write({g});
  }
  CHECK_THROWS_WITH(TsdfVolume::load(path), Catch::Contains("voxel_size_m") && Catch::Contains(path.string()));
}

TEST_CASE("bad input is refused with a message that names what is wrong, and changes nothing", "[tsdf][bad-input]") {
  TsdfConfig c;
  c.voxel_size_m = -0.1;
  CHECK_THROWS_WITH(TsdfVolume(c), Catch::Contains("voxel_size_m"));
  c = TsdfConfig{};
  c.truncation_vox = 0.5;
  CHECK_THROWS_WITH(TsdfVolume(c), Catch::Contains("truncation_vox"));
  IntegratorConfig in;
  in.min_range_m = 6.0;
  CHECK_THROWS_WITH(TsdfVolume(TsdfConfig{}, in), Catch::Contains("min_range_m"));

  const auto poses = randomPoses(2, 51);
  const auto frames = randomFrames(poses, 52);
  TsdfVolume volume(config(0.1));
  volume.integrate(0, frames[0], poses[0]);
  TsdfVolume before(config(0.1));
  before.integrate(0, frames[0], poses[0]);

  CHECK_THROWS_WITH(volume.deintegrate(7, frames[0], poses[0]), Catch::Contains("frame 7") && Catch::Contains("never integrated"));
  CHECK_THROWS_WITH(volume.deintegrate(0, frames[0], poses[1]), Catch::Contains("frame 0"));
  CHECK_THROWS_WITH(volume.integrate(0, frames[1], poses[1]), Catch::Contains("already integrated"));
  Pose3d bad = poses[1];
  bad.linear()(0, 0) = 2.0;
  CHECK_THROWS_WITH(volume.integrate(1, frames[1], bad), Catch::Contains("frame 1") && Catch::Contains("rigid"));
  CHECK(volume.exactlyEquals(before));

  const PointCloud nans(1000, Vec3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  const IntegrationStats stats = volume.integrate(9, nans, poses[1]);
  CHECK(stats.points_total == 1000);
  CHECK(stats.points_invalid == 1000);
  CHECK(stats.rays_cast == 0);
  CHECK(volume.exactlyEquals(before));
}

TEST_CASE("a copy of a map is deep: integrating into one leaves the other unchanged", "[tsdf]") {
  const auto poses = randomPoses(2, 7);
  const auto frames = randomFrames(poses, 8);
  TsdfVolume original(config(0.1));
  original.integrate(0, frames[0], poses[0]);
  TsdfVolume reference(config(0.1));
  reference.integrate(0, frames[0], poses[0]);

  TsdfVolume copy = original;
  CHECK(copy.exactlyEquals(original));
  CHECK(copy.isIntegrated(0));
  copy.integrate(1, frames[1], poses[1]);
  CHECK(original.exactlyEquals(reference));
  CHECK_FALSE(original.isIntegrated(1));
  CHECK_FALSE(copy.exactlyEquals(original));

  TsdfVolume assigned(config(0.2));
  assigned = copy;
  copy.deintegrate(1, frames[1], poses[1]);
  CHECK(copy.exactlyEquals(reference));
  CHECK(assigned.isIntegrated(1));
  CHECK(assigned.config().voxel_size_m == 0.1);
  CHECK(assigned.weightSumGrid()->transform() == copy.weightSumGrid()->transform());
}
