// Correcting a saved map afterwards: the keyframe store's file round-trips exactly and refuses
// bad files by name; a mapper loaded from a saved map and corrected equals integrating its frames
// from scratch at the corrected poses, bit for bit; a store or a companion of another save is
// refused by its unit id; a save that fails part way changes nothing and leaves no temporaries.
#include "common/drifting_circle.hpp"
#include "common/fresh_dir.hpp"
#include "test_io_helpers.hpp"
#include "vdbmap/file_error.hpp"
#include "vdbmap/map_file.hpp"
#include "vdbmap/mapper.hpp"
#include "vdbmap/testing/analytic_scene.hpp"

#include <catch2/catch.hpp>
#include <zlib.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

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

/// Adds depth frames 0..depth_frames-1 of the demo room seen along the drifting circle, and with
/// `points` a point frame of two points (id 7).
void addFrames(Mapper& mapper, int depth_frames, bool points = false) {
  for (int i = 0; i < depth_frames; ++i)
    mapper.addFrame(i, 0.1 * i, SensorFrame::depth(kScene.renderDepth(*camera(), test::circlePose(i), 5.0), camera()),
                    test::circleOdometry(i));
  if (points)
    mapper.addFrame(7, 0.5, SensorFrame::points({Vec3f(1, 2, 3), Vec3f(0.5f, -0.25f, 2.0f)}), test::circleOdometry(7));
}

/// Saves a keyframe store of addFrames(depth_frames, points) to `file`; returns its bytes.
std::string savedStore(const fs::path& file, int depth_frames, bool points = false) {
  Mapper mapper(config(ConsistencyMode::All));
  addFrames(mapper, depth_frames, points);
  mapper.keyframes().save(file);
  return test::readBytes(file);
}

template <typename T>
T valueAt(const std::string& bytes, std::size_t at) {
  REQUIRE(at + sizeof(T) <= bytes.size());
  T v;
  std::memcpy(&v, bytes.data() + at, sizeof(T));
  return v;
}

/// One keyframe record of a store file, as docs/formats.md lays it out: from its id to its
/// payload's end (in version 3 a CRC-32 of those bytes follows), where its payload size and
/// payload lie, and what its codes are.
struct StoreRecord {
  std::size_t begin = 0, compressed_at = 0, count_at = 0, payload_size_at = 0, payload_begin = 0, payload_end = 0;
  bool depth = false, compressed = false;
  std::uint32_t count = 0;  ///< pixels or points
};

struct StoreFile {
  std::uint32_t version = 0;
  std::size_t header_end = 0;  ///< where the first record begins
  std::vector<StoreRecord> records;
};

/// Walks a store file's records (the test's own reading of the layout, not the library's).
StoreFile parseStore(const std::string& bytes) {
  StoreFile f;
  f.version = valueAt<std::uint32_t>(bytes, 8);
  const std::uint32_t id_bytes = valueAt<std::uint32_t>(bytes, 12);
  const std::uint64_t count = valueAt<std::uint64_t>(bytes, 16);
  std::size_t pos = f.header_end = 24 + id_bytes;
  for (std::uint64_t k = 0; k < count; ++k) {
    StoreRecord r;
    r.begin = pos;
    pos += 8 + 8 + 2 * 16 * 8 + 1;  // id, stamp, two poses, integrated
    r.depth = bytes.at(pos) == 0;
    r.compressed_at = pos + 1;
    r.compressed = bytes.at(r.compressed_at) != 0;
    const bool has_camera = bytes.at(pos + 2) != 0;
    r.count_at = pos + 3 + 4;
    r.count = valueAt<std::uint32_t>(bytes, r.count_at);
    pos += 3 + 4 + 4 + 8 + (has_camera ? 8 + 4 * 8 : 0);  // flags, stride, count, unit, camera
    r.payload_size_at = pos;
    r.payload_begin = pos + 8;
    r.payload_end = r.payload_begin + valueAt<std::uint64_t>(bytes, pos);
    pos = r.payload_end + (f.version >= 3 ? 4 : 0);
    f.records.push_back(r);
  }
  REQUIRE(pos == bytes.size());
  return f;
}

/// A version 3 store as the version 2 writer wrote it (no checksums), or version 1 (nor unit id).
std::string legacyStore(const std::string& v3, std::uint32_t version) {
  const StoreFile f = parseStore(v3);
  REQUIRE(f.version == 3);
  std::string out = v3.substr(0, f.header_end);
  out.replace(8, 4, reinterpret_cast<const char*>(&version), 4);
  if (version == 1) {
    const std::uint32_t none = 0;
    out.erase(24);
    out.replace(12, 4, reinterpret_cast<const char*>(&none), 4);
  }
  for (const StoreRecord& r : f.records) out.append(v3, r.begin, r.payload_end - r.begin);
  return out;
}

}  // namespace

TEST_CASE("a keyframe store saved and loaded holds the same frames, poses and data", "[mapper][saved]") {
  const fs::path dir = test::freshDir("vdbmap_saved_store");
  Mapper mapper(config(ConsistencyMode::All));
  addFrames(mapper, 3, true);
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
  addFrames(mapper, 2);
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
  patch(bad, 24 + 32 + 16, &nan, 8);  // after the header and the unit id: the first keyframe's T_W_S_integrated(0, 0)
  CHECK_THROWS_WITH(KeyframeStore::load(bad), Catch::Contains("keyframe 0 (id 0)") && Catch::Contains("T_W_S_integrated"));
  fresh();
  std::ofstream(bad, std::ios::app) << "extra";
  CHECK_THROWS_WITH(KeyframeStore::load(bad), Catch::Contains("bytes after the last keyframe"));
  CHECK_THROWS_AS(KeyframeStore::load(dir / "missing.keyframes"), FileError);
}

TEST_CASE("a keyframe store with any one byte damaged is refused naming the file, and the keyframe within a record",
          "[mapper][saved][hostile]") {
  // Two depth frames and a point frame; each record's CRC-32 covers what no other check can:
  // a stride, a unit or a code changed is a frame the map never integrated.
  const fs::path dir = test::freshDir("vdbmap_saved_every_byte");
  const fs::path good = dir / "good.keyframes", bad = dir / "bad.keyframes";
  const std::string bytes = savedStore(good, 2, true);
  REQUIRE(KeyframeStore::load(good).size() == 3);
  const StoreFile layout = parseStore(bytes);
  REQUIRE(layout.version == 3);
  REQUIRE(layout.records.size() == 3);
  std::size_t refused = 0;
  for (std::size_t at = 0; at < bytes.size(); ++at) {
    std::string damaged = bytes;
    damaged[at] = char(damaged[at] ^ 0xff);
    { std::ofstream(bad, std::ios::binary | std::ios::trunc) << damaged; }
    std::size_t record = 0;
    while (record + 1 < layout.records.size() && layout.records[record + 1].begin <= at) ++record;
    const bool in_record = at >= layout.header_end;
    try {
      (void)KeyframeStore::load(bad);
      FAIL_CHECK("byte " << at << " damaged, and the store loaded");
    } catch (const FileError& e) {
      const std::string what = e.what();
      INFO("byte " << at << ": " << what);
      CHECK(what.find("bad.keyframes") != std::string::npos);
      if (in_record) CHECK(what.find("keyframe " + std::to_string(record)) != std::string::npos);
      ++refused;
    }
  }
  CHECK(refused == bytes.size());
}

TEST_CASE("a keyframe record's count beyond what its payload holds is refused before anything is allocated for it",
          "[mapper][saved][hostile]") {
  const fs::path dir = test::freshDir("vdbmap_saved_counts");
  const std::string bytes = savedStore(dir / "good.keyframes", 0, true);
  const StoreRecord r = parseStore(bytes).records.at(0);
  REQUIRE_FALSE(r.depth);
  // 2^32 - 1 points ask for 51 GB of codes, from a payload of a few bytes: refused by the payload's size.
  std::string damaged = bytes;
  const std::uint32_t huge = 0xffffffffu;
  damaged.replace(r.count_at, 4, reinterpret_cast<const char*>(&huge), 4);
  std::ofstream(dir / "huge.keyframes", std::ios::binary) << damaged;
  CHECK_THROWS_WITH(KeyframeStore::load(dir / "huge.keyframes"),
                    Catch::Contains("keyframe 0 (id 7)") &&
                        Catch::Contains("count 4294967295 needs 51539607540 bytes") &&
                        Catch::Contains("more than a compressed payload"));
  // A payload said to be raw codes must hold exactly the count's.
  damaged = bytes;
  damaged[r.compressed_at] = 0;
  std::ofstream(dir / "raw.keyframes", std::ios::binary) << damaged;
  CHECK_THROWS_WITH(KeyframeStore::load(dir / "raw.keyframes"), Catch::Contains("keyframe 0 (id 7)") &&
                                                                    Catch::Contains("raw payload of") &&
                                                                    Catch::Contains("count 2 needs 24"));
}

TEST_CASE("a version 2 keyframe store (no checksums) whose payload does not decode is refused naming the keyframe",
          "[mapper][saved][hostile]") {
  const fs::path dir = test::freshDir("vdbmap_saved_v2_payload");
  std::string v2 = legacyStore(savedStore(dir / "v3.keyframes", 2), 2);
  std::ofstream(dir / "v2.keyframes", std::ios::binary) << v2;
  REQUIRE(KeyframeStore::load(dir / "v2.keyframes").size() == 2);
  // A byte of the second frame's zlib stream changed: its Adler-32 (or the stream) no longer holds.
  const StoreRecord r = parseStore(v2).records.at(1);
  const std::size_t middle = (r.payload_begin + r.payload_end) / 2;
  v2[middle] = char(v2[middle] ^ 0xff);
  std::ofstream(dir / "v2_bad.keyframes", std::ios::binary | std::ios::trunc) << v2;
  CHECK_THROWS_WITH(KeyframeStore::load(dir / "v2_bad.keyframes"), Catch::Contains("v2_bad.keyframes") &&
                                                                       Catch::Contains("keyframe 1 (id 1)") &&
                                                                       Catch::Contains("payload"));
}

TEST_CASE("keyframe stores that another writer made from docs/formats.md load in every version", "[mapper][saved]") {
  // fuzz/make_corpus.py writes them with Python's struct and zlib (fuzz_keyframes' seeds): an
  // 8x6 depth frame (id 0) and two points (id 7), compressed, and raw in version 3.
  const fs::path seeds = fs::path(VDBMAP_SOURCE_DIR) / "fuzz" / "seeds" / "fuzz_keyframes";
  for (const char* name : {"store_v1.keyframes", "store_v2.keyframes", "store_v3.keyframes", "raw_v3.keyframes"}) {
    INFO(name);
    const KeyframeStore store = KeyframeStore::load(seeds / name);
    REQUIRE(store.size() == 2);
    CHECK(KeyframeStore::savedUnitId(seeds / name) ==
          (std::string(name) == "store_v1.keyframes" ? "" : "0123456789abcdef0123456789abcdef"));
    const Keyframe& depth = store.at(0);
    REQUIRE(depth.data.isDepth());
    const DepthImage image = depth.data.decodeDepth();
    REQUIRE((image.width == 8 && image.height == 6));
    for (int v = 0; v < 6; ++v)
      for (int u = 0; u < 8; ++u) CHECK(image.at(u, v) == Approx(1.0 + 0.01 * u + 0.1 * v).margin(1e-6));
    const Keyframe& points = store.at(7);
    CHECK(points.timestamp == 1.5);
    CHECK(points.T_W_S_latest.translation().isApprox(Vec3d(0.7, 0, 0)));
    const PointCloud p = points.data.decode();
    REQUIRE(p.size() == 2);
    CHECK(p[0].isApprox(Vec3f(1, 2, 3)));
    CHECK(p[1].isApprox(Vec3f(0.5f, -0.25f, 2.0f)));
  }
}

TEST_CASE("version 1 and 2 keyframe stores (no unit id, no checksums) still load", "[mapper][saved]") {
  const fs::path dir = test::freshDir("vdbmap_saved_v1");
  // Version 1: the same file without the unit id, its size field 0 (then reserved), and without
  // the records' checksums (version 3).
  const std::string v3 = savedStore(dir / "v3.keyframes", 2);
  REQUIRE(KeyframeStore::savedUnitId(dir / "v3.keyframes").size() == 32);
  std::ofstream(dir / "v1.keyframes", std::ios::binary) << legacyStore(v3, 1);
  std::ofstream(dir / "v2.keyframes", std::ios::binary) << legacyStore(v3, 2);
  CHECK(KeyframeStore::savedUnitId(dir / "v1.keyframes").empty());
  CHECK(KeyframeStore::load(dir / "v1.keyframes").size() == 2);
  CHECK(KeyframeStore::savedUnitId(dir / "v2.keyframes") == KeyframeStore::savedUnitId(dir / "v3.keyframes"));
  CHECK(KeyframeStore::load(dir / "v2.keyframes").size() == 2);
}

TEST_CASE("a keyframe store whose payloads zlib wrote (every store saved before libdeflate) decodes the same",
          "[mapper][saved]") {
  const fs::path dir = test::freshDir("vdbmap_saved_zlib");
  Mapper mapper(config(ConsistencyMode::All));
  addFrames(mapper, 3, true);
  mapper.keyframes().save(dir / "new.keyframes");
  // Every payload inflated and deflated again by zlib's compress2 at level 1, as the store did
  // before, in a version 2 file (no checksums) as the stores of then were.
  const std::string in = legacyStore(test::readBytes(dir / "new.keyframes"), 2);
  const StoreFile layout = parseStore(in);
  std::string out = in.substr(0, layout.header_end);
  int replaced = 0;
  for (const StoreRecord& r : layout.records) {
    REQUIRE(r.compressed);
    out.append(in, r.begin, r.payload_size_at - r.begin);
    const std::string payload = in.substr(r.payload_begin, r.payload_end - r.payload_begin);
    // The raw codes: a 16-bit code per pixel, or three 32-bit codes per point.
    std::vector<Bytef> raw(std::size_t(r.count) * (r.depth ? 2 : 12));
    uLongf raw_n = uLongf(raw.size());
    REQUIRE(uncompress(raw.data(), &raw_n, reinterpret_cast<const Bytef*>(payload.data()), uLong(payload.size())) ==
            Z_OK);
    REQUIRE(raw_n == raw.size());
    std::vector<Bytef> packed(compressBound(raw_n));
    uLongf packed_n = uLongf(packed.size());
    REQUIRE(compress2(packed.data(), &packed_n, raw.data(), raw_n, 1) == Z_OK);
    const std::uint64_t size = packed_n;
    out.append(reinterpret_cast<const char*>(&size), 8);
    out.append(reinterpret_cast<const char*>(packed.data()), packed_n);
    replaced += std::string(reinterpret_cast<const char*>(packed.data()), packed_n) != payload;
  }
  CHECK(replaced >= 1);  // zlib's streams are not libdeflate's, so the file really changed
  std::ofstream(dir / "zlib.keyframes", std::ios::binary) << out;
  const KeyframeStore loaded = KeyframeStore::load(dir / "zlib.keyframes");
  REQUIRE(loaded.size() == mapper.keyframes().size());
  for (const auto& [id, kf] : mapper.keyframes()) {
    INFO("keyframe " << id);
    const PointCloud a = kf.data.decode(), b = loaded.at(id).data.decode();
    REQUIRE(a.size() == b.size());
    for (std::size_t i = 0; i < a.size(); ++i)
      CHECK(((a[i].array() == b[i].array()).all() || (!a[i].allFinite() && !b[i].allFinite())));
  }
}

TEST_CASE("a saved map corrected after loading equals integrating its frames from scratch at the corrected poses",
          "[mapper][saved]") {
  for (const ConsistencyMode mode : {ConsistencyMode::All, ConsistencyMode::Keyframes}) {
    INFO("mode " << toString(mode));
    const fs::path dir = test::freshDir("vdbmap_saved_correct");
    {
      Mapper mapper(config(mode));
      addFrames(mapper, kFrames);
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
      scratch.addFrame(id, kf.timestamp, SensorFrame::depth(kf.data.decodeDepth(), kf.data.intrinsics()), test::circlePose(int(id)));
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
    addFrames(mapper, n);
    mapper.save(dir / (std::string(name) + ".vdb"));
  }
  fs::copy_file(dir / "b.keyframes", dir / "a.keyframes", fs::copy_options::overwrite_existing);
  CHECK_THROWS_WITH(Mapper::load(dir / "a.vdb"), Catch::Contains("a.keyframes belongs to another save than") &&
                                                     Catch::Contains("a.vdb") && Catch::Contains("unit id"));
  fs::remove(dir / "b.keyframes");
  CHECK_THROWS_WITH(Mapper::load(dir / "b.vdb"), Catch::Contains("no keyframe store"));
  fs::remove(dir / "b.exact.vdb");
  CHECK_THROWS_WITH(Mapper::load(dir / "b.vdb"), Catch::Contains("no exact companion"));
  Mapper queued(config(ConsistencyMode::All));
  queued.addFrame(0, 0.0, SensorFrame::depth(kScene.renderDepth(*camera(), test::circlePose(0), 5.0), camera()), test::circleOdometry(0));
  queued.updatePoses({{0, test::circlePose(5)}});
  CHECK_THROWS_AS(queued.save(dir / "q.vdb"), std::logic_error);
}

TEST_CASE("a map and an exact companion of different saves are refused, naming both files", "[tsdf][saved][hostile]") {
  const fs::path dir = test::freshDir("vdbmap_saved_unit");
  Mapper mapper(config(ConsistencyMode::All));
  addFrames(mapper, 2);
  const TsdfVolume& volume = mapper.volume();
  volume.save(dir / "a.vdb");
  volume.save(dir / "b.vdb");  // the same state, another save (as a second writer, or a later save)
  const std::string unit_a = TsdfVolume::savedUnitId(dir / "a.vdb");
  CHECK(unit_a.size() == 32);
  CHECK(unit_a != TsdfVolume::savedUnitId(dir / "b.vdb"));
  CHECK(inspectMapFile(dir / "a.vdb").has_exact_state);
  CHECK(inspectMapFile(dir / "a.vdb").unit_id == unit_a);

  // What a stop between the companion's rename and the map's leaves: the new companion, the old map.
  fs::copy_file(dir / "b.exact.vdb", dir / "a.exact.vdb", fs::copy_options::overwrite_existing);
  CHECK_THROWS_WITH(TsdfVolume::load(dir / "a.vdb"), Catch::Contains("a.exact.vdb belongs to another save than") &&
                                                         Catch::Contains("a.vdb") && Catch::Contains(unit_a));
  const MapFileInfo info = inspectMapFile(dir / "a.vdb");
  CHECK_FALSE(info.has_exact_state);
  CHECK_THAT(info.exact_state_problem, Catch::Contains("another save"));

  // A companion that is not a map at all: info says why, load names it.
  std::ofstream(dir / "b.exact.vdb", std::ios::trunc) << "garbage";
  CHECK_FALSE(inspectMapFile(dir / "b.vdb").has_exact_state);
  CHECK_THAT(inspectMapFile(dir / "b.vdb").exact_state_problem, Catch::Contains("b.exact.vdb"));
  CHECK_THROWS_WITH(TsdfVolume::load(dir / "b.vdb"), Catch::Contains("b.exact.vdb") && Catch::Contains("truncated or damaged"));

  // Without a companion the map loads approximately, as before.
  fs::remove(dir / "a.exact.vdb");
  CHECK_FALSE(TsdfVolume::load(dir / "a.vdb").hasExactState());
}

TEST_CASE("a map name that is a companion's name is refused before anything is written", "[tsdf][saved][hostile]") {
  const fs::path dir = test::freshDir("vdbmap_saved_names");
  Mapper mapper(config(ConsistencyMode::All));
  addFrames(mapper, 1);
  CHECK_THROWS_WITH(mapper.volume().save(dir / "x.exact.vdb"), Catch::Contains("x.exact.vdb") && Catch::Contains("companion"));
  CHECK_THROWS_WITH(mapper.save(dir / "x.keyframes"), Catch::Contains("x.keyframes") && Catch::Contains("keyframe store"));
  CHECK(fs::is_empty(dir));
}

TEST_CASE("a save that fails part way leaves the previous files as they were and no temporaries", "[mapper][saved][hostile]") {
  const fs::path dir = test::freshDir("vdbmap_saved_failed");
  Mapper first(config(ConsistencyMode::All));
  first.addFrame(0, 0.0, SensorFrame::depth(kScene.renderDepth(*camera(), test::circlePose(0), 5.0), camera()), test::circleOdometry(0));
  first.save(dir / "m.vdb");
  const std::string map_before = test::readBytes(dir / "m.vdb"), store_before = test::readBytes(dir / "m.keyframes");
  // The companion's name is taken by a folder: the store is staged first, then the companion fails.
  fs::remove(dir / "m.exact.vdb");
  fs::create_directory(dir / "m.exact.vdb");
  Mapper second(config(ConsistencyMode::All));
  for (int i = 0; i < 3; ++i) second.addFrame(i, 0.1 * i, SensorFrame::depth(kScene.renderDepth(*camera(), test::circlePose(i), 5.0), camera()), test::circleOdometry(i));
  CHECK_THROWS_WITH(second.save(dir / "m.vdb"), Catch::Contains("m.exact.vdb") && Catch::Contains("folder"));
  CHECK(test::readBytes(dir / "m.vdb") == map_before);
  CHECK(test::readBytes(dir / "m.keyframes") == store_before);
  for (const auto& entry : fs::directory_iterator(dir))
    CHECK_THAT(entry.path().filename().string(), !Catch::Contains(".tmp."));
}

TEST_CASE("a save removes temporaries that a killed save of the same map left, and no one else's", "[tsdf][saved][hostile]") {
  const fs::path dir = test::freshDir("vdbmap_saved_stale");
  // A process that has ended: its pid is free (until reused, which a fresh waitpid makes unlikely).
  const pid_t dead = ::fork();
  REQUIRE(dead >= 0);
  if (dead == 0) std::_Exit(0);
  int status = 0;
  REQUIRE(::waitpid(dead, &status, 0) == dead);
  const fs::path stale = dir / ("m.vdb.tmp." + std::to_string(dead) + ".0");
  const fs::path stale_companion = dir / ("m.exact.vdb.tmp." + std::to_string(dead) + ".3");
  const fs::path live = dir / ("m.vdb.tmp." + std::to_string(::getppid()) + ".0");  // our parent runs
  const fs::path other = dir / ("n.vdb.tmp." + std::to_string(dead) + ".0");           // another map's
  for (const fs::path& p : {stale, stale_companion, live, other}) std::ofstream(p) << "half a file";
  Mapper mapper(config(ConsistencyMode::None));
  addFrames(mapper, 1);
  mapper.volume().save(dir / "m.vdb");
  CHECK_FALSE(fs::exists(stale));
  CHECK_FALSE(fs::exists(stale_companion));
  CHECK(fs::exists(live));
  CHECK(fs::exists(other));
  CHECK(TsdfVolume::load(dir / "m.vdb").hasExactState());
}
