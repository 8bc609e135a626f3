// Correcting a saved map afterwards: the keyframe store's file round-trips exactly and refuses
// bad files by name; a mapper loaded from a saved map and corrected equals integrating its frames
// from scratch at the corrected poses, bit for bit; a store of another run is refused.
#include "common/drifting_circle.hpp"
#include "common/fresh_dir.hpp"
#include "vdbmap/file_error.hpp"
#include "vdbmap/mapper.hpp"
#include "vdbmap/testing/analytic_scene.hpp"

#include <catch2/catch.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>

using namespace vdbmap;
namespace fs = std::filesystem;

namespace {

std::shared_ptr<const CameraIntrinsics> camera() { return std::make_shared<const CameraIntrinsics>(CameraIntrinsics{160, 120, 96.8, 96.8, 79.5, 59.5}); }


MapperConfig config(ConsistencyMode mode) {
  MapperConfig c;
  c.mode = mode;
  c.tsdf.voxel_size_m = 0.1;
  c.integrator.max_range_m = 5.0;
  return c;
}

/// Overwrites `n` bytes at `offset` of a file.
void patch(const fs::path& path, std::size_t offset, const void* bytes, std::size_t n) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  f.seekp(std::streamoff(offset));
  f.write(static_cast<const char*>(bytes), std::streamsize(n));
}

const testing::AnalyticScene kScene = testing::AnalyticScene::demoRoom();
constexpr int kFrames = 8;

}  // namespace

TEST_CASE("a keyframe store saved and loaded holds the same frames, poses and data", "[mapper][saved]") {
  const fs::path dir = test::freshDir("vdbmap_saved_store");
  Mapper mapper(config(ConsistencyMode::All));
  for (int i = 0; i < 3; ++i) mapper.addDepthFrame(i, 0.1 * i, kScene.renderDepth(*camera(), test::circlePose(i), 5.0), camera(), test::circleOdometry(i));
  mapper.addPointFrame(7, 0.5, {Vec3f(1, 2, 3), Vec3f(0.5f, -0.25f, 2.0f)}, test::circleOdometry(7));
  mapper.keyframes().save(dir / "s.keyframes");
  const KeyframeStore loaded = KeyframeStore::load(dir / "s.keyframes");
  REQUIRE(loaded.size() == mapper.keyframes().size());
  for (const auto& [id, kf] : mapper.keyframes()) {
    const Keyframe& k = loaded.at(id);
    CHECK(k.timestamp == kf.timestamp);
    CHECK(k.T_W_S_integrated.matrix() == kf.T_W_S_integrated.matrix());
    CHECK(k.T_W_S_latest.matrix() == kf.T_W_S_latest.matrix());
    CHECK(k.integrated == kf.integrated);
    CHECK(k.data.isDepth() == kf.data.isDepth());
    const PointCloud a = k.data.decode(), b = kf.data.decode();
    REQUIRE(a.size() == b.size());
    for (std::size_t p = 0; p < a.size(); ++p)
      CHECK(((a[p].array() == b[p].array()).all() || (!a[p].allFinite() && !b[p].allFinite())));
  }
}

TEST_CASE("bad keyframe store files are refused naming the file, the keyframe and the field", "[mapper][saved][hostile]") {
  const fs::path dir = test::freshDir("vdbmap_saved_hostile");
  Mapper mapper(config(ConsistencyMode::All));
  for (int i = 0; i < 2; ++i) mapper.addDepthFrame(i, 0.1 * i, kScene.renderDepth(*camera(), test::circlePose(i), 5.0), camera(), test::circleOdometry(i));
  const fs::path good = dir / "good.keyframes", bad = dir / "bad.keyframes";
  mapper.keyframes().save(good);
  const auto fresh = [&] { fs::copy_file(good, bad, fs::copy_options::overwrite_existing); };

  fresh();
  fs::resize_file(bad, fs::file_size(good) - 10);
  CHECK_THROWS_WITH(KeyframeStore::load(bad), Catch::Contains("bad.keyframes") && Catch::Contains("keyframe 1") &&
                                                  Catch::Contains("payload"));
  fresh();
  patch(bad, 0, "NOTAMAP!", 8);
  CHECK_THROWS_WITH(KeyframeStore::load(bad), Catch::Contains("not a vdbmap keyframe store"));
  fresh();
  const std::uint32_t version = 99;
  patch(bad, 8, &version, 4);
  CHECK_THROWS_WITH(KeyframeStore::load(bad), Catch::Contains("version 99"));
  fresh();
  const std::uint64_t count = std::uint64_t(1) << 60;  // no allocation for it: refused by the file's size
  patch(bad, 16, &count, 8);
  CHECK_THROWS_WITH(KeyframeStore::load(bad), Catch::Contains("more than its"));
  fresh();
  const double nan = std::nan("");
  patch(bad, 24 + 16, &nan, 8);  // the first keyframe's T_W_S_integrated(0, 0)
  CHECK_THROWS_WITH(KeyframeStore::load(bad), Catch::Contains("keyframe 0 (id 0)") && Catch::Contains("T_W_S_integrated"));
  fresh();
  std::ofstream(bad, std::ios::app) << "extra";
  CHECK_THROWS_WITH(KeyframeStore::load(bad), Catch::Contains("bytes after the last keyframe"));
  CHECK_THROWS_AS(KeyframeStore::load(dir / "missing.keyframes"), FileError);
}

TEST_CASE("a saved map corrected after loading equals integrating its frames from scratch at the corrected poses",
          "[mapper][saved]") {
  for (const ConsistencyMode mode : {ConsistencyMode::All, ConsistencyMode::Keyframes}) {
    INFO("mode " << toString(mode));
    const fs::path dir = test::freshDir("vdbmap_saved_correct");
    {
      Mapper mapper(config(mode));
      for (int i = 0; i < kFrames; ++i)
        mapper.addDepthFrame(i, 0.1 * i, kScene.renderDepth(*camera(), test::circlePose(i), 5.0), camera(), test::circleOdometry(i));
      mapper.reintegrateAll(Vec3d::Zero());
      mapper.save(dir / "map.vdb");
      CHECK(fs::exists(dir / "map.keyframes"));
      CHECK(fs::exists(dir / "map.exact.vdb"));
    }
    Mapper loaded = Mapper::load(dir / "map.vdb");
    CHECK(loaded.config().mode == ConsistencyMode::All);
    std::map<FrameId, Pose3d> corrected;
    for (const auto& [id, kf] : loaded.keyframes()) corrected[id] = test::circlePose(int(id));
    // Every kept frame drifted beyond the gates but frame 0 (where the drift starts).
    CHECK(loaded.updatePoses(corrected) == corrected.size() - corrected.count(0));
    loaded.reintegrateAll(Vec3d::Zero());

    Mapper scratch(config(ConsistencyMode::None));
    for (const auto& [id, kf] : loaded.keyframes())
      scratch.addDepthFrame(id, kf.timestamp, kf.data.decodeDepth(), kf.data.intrinsics(), test::circlePose(int(id)));
    CHECK(loaded.volume().exactlyEquals(scratch.volume()));

    // Saved again, it loads again (the corrected poses are the ones the map now holds).
    loaded.save(dir / "corrected.vdb");
    CHECK(Mapper::load(dir / "corrected.vdb").volume().exactlyEquals(scratch.volume()));
  }
}

TEST_CASE("a saved map is refused without its exact state or with another run's keyframes", "[mapper][saved][hostile]") {
  const fs::path dir = test::freshDir("vdbmap_saved_mismatch");
  for (const char* name : {"a", "b"}) {
    Mapper mapper(config(ConsistencyMode::All));
    const int n = std::string(name) == "a" ? 3 : 2;
    for (int i = 0; i < n; ++i)
      mapper.addDepthFrame(i, 0.1 * i, kScene.renderDepth(*camera(), test::circlePose(i), 5.0), camera(), test::circleOdometry(i));
    mapper.save(dir / (std::string(name) + ".vdb"));
  }
  fs::copy_file(dir / "b.keyframes", dir / "a.keyframes", fs::copy_options::overwrite_existing);
  CHECK_THROWS_WITH(Mapper::load(dir / "a.vdb"), Catch::Contains("a.vdb holds 3 frames") && Catch::Contains("not of the same run"));
  fs::remove(dir / "b.keyframes");
  CHECK_THROWS_WITH(Mapper::load(dir / "b.vdb"), Catch::Contains("no keyframe store"));
  fs::remove(dir / "b.exact.vdb");
  CHECK_THROWS_WITH(Mapper::load(dir / "b.vdb"), Catch::Contains("no exact companion"));
  Mapper queued(config(ConsistencyMode::All));
  queued.addDepthFrame(0, 0.0, kScene.renderDepth(*camera(), test::circlePose(0), 5.0), camera(), test::circleOdometry(0));
  queued.updatePoses({{0, test::circlePose(5)}});
  CHECK_THROWS_AS(queued.save(dir / "q.vdb"), std::logic_error);
}
