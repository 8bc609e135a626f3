// Hostile input: files whose headers declare sizes they do not hold (a 45-byte PNG claiming
// 100000 x 100000 pixels, a PLY or PCD claiming 1e12 points, an OFF claiming 1e12 vertices) are
// refused before anything is allocated, with the file, the element or field and the declared
// count named; control bytes quoted from a file are escaped; a map of a newer format is refused;
// writing over a folder says so; a write stopped by a signal leaves no temporary. Every hostile file
// is a few bytes written here.
#include "test_io_helpers.hpp"
#include "tsdf_test_helpers.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/camera.hpp"
#include "vdbmap/eval.hpp"
#include "vdbmap/file_error.hpp"
#include "vdbmap/io/errors.hpp"
#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/io/png_io.hpp"
#include "vdbmap/io/point_cloud_io.hpp"
#include "vdbmap/keyframe_store.hpp"
#include "vdbmap/map_file.hpp"
#include "vdbmap/mapper.hpp"
#include "vdbmap/openvdb.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <initializer_list>
#include <limits>
#include <ostream>
#include <stdexcept>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

using namespace vdbmap;
using vdbmap::test::TempDir;
using vdbmap::test::readBytes;
using vdbmap::test::writeText;

namespace {

std::string be32(std::uint32_t v) {
  return {char(v >> 24), char((v >> 16) & 0xff), char((v >> 8) & 0xff), char(v & 0xff)};
}

std::string le32(std::uint32_t v) {
  return {char(v & 0xff), char((v >> 8) & 0xff), char((v >> 16) & 0xff), char(v >> 24)};
}

std::uint32_t crc32(const std::string& bytes) {
  std::uint32_t c = 0xffffffffu;
  for (const char ch : bytes) {
    c ^= std::uint8_t(ch);
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return c ^ 0xffffffffu;
}

std::string pngChunk(const std::string& type, const std::string& data) {
  return be32(std::uint32_t(data.size())) + type + data + be32(crc32(type + data));
}

/// A well-formed PNG header (signature, IHDR with a valid CRC, IEND) declaring `width` x `height`
/// pixels and holding none: 45 bytes.
std::string hostilePng(std::uint32_t width, std::uint32_t height, int bit_depth = 16, int color_type = 0) {
  const std::string ihdr = be32(width) + be32(height) + std::string{char(bit_depth), char(color_type), 0, 0, 0};
  return std::string("\x89PNG\r\n\x1a\n", 8) + pngChunk("IHDR", ihdr) + pngChunk("IEND", "");
}

/// Requires `fn` to throw vdbmap::FileError whose message holds every fragment; returns the message.
template <typename Fn>
std::string requireFileErrorMentioning(Fn&& fn, std::initializer_list<std::string> fragments) {
  std::string msg;
  bool thrown = false;
  try {
    fn();
  } catch (const FileError& e) {
    thrown = true;
    msg = e.what();
    INFO("message: " << msg);
    for (const std::string& f : fragments) CHECK(msg.find(f) != std::string::npos);
  }
  CHECK(thrown);
  return msg;
}

/// Rewrites the metadata `vdbmap_format_version` of the map `from` into `to`.
void copyWithFormatVersion(const std::filesystem::path& from, const std::filesystem::path& to, int version) {
  test::rewriteVdbFile(from, to, {}, [version](openvdb::MetaMap& meta) {
    meta.removeMeta("vdbmap_format_version");
    meta.insertMeta("vdbmap_format_version", openvdb::Int32Metadata(version));
  });
}

}  // namespace

TEST_CASE("a PNG header beyond 16384 pixels a side is refused before decoding, naming the file and size",
          "[io][png][hostile]") {
  TempDir dir;
  writeText(dir / "huge.png", hostilePng(100000, 100000));
  requireFileErrorMentioning([&] { io::readDepthPng(dir / "huge.png", 0.001); },
                             {"huge.png", "100000x100000", "16384"});
  requireFileErrorMentioning([&] { io::readPng(dir / "huge.png"); }, {"huge.png", "100000x100000", "16384"});
  int w = 0, h = 0;
  requireFileErrorMentioning([&] { io::readPngSize(dir / "huge.png", w, h); }, {"huge.png", "100000x100000"});
}

TEST_CASE("a PNG header declaring more pixel data than the file can hold compressed is refused",
          "[io][png][hostile]") {
  TempDir dir;
  // Within the side limit, but 512 MiB of 16-bit pixels (or 32 MiB of 1-bit ones) from 45 bytes.
  writeText(dir / "big16.png", hostilePng(16384, 16384));
  requireFileErrorMentioning([&] { io::readDepthPng(dir / "big16.png", 0.001); },
                             {"big16.png", "16384x16384", "536870912 bytes of pixel data", "45-byte file"});
  writeText(dir / "big1.png", hostilePng(16384, 16384, 1, 0));
  requireFileErrorMentioning([&] { io::readPng(dir / "big1.png"); }, {"big1.png", "16384x16384"});
}

TEST_CASE("an image at the side limit is written and read back", "[io][png][hostile]") {
  TempDir dir;
  io::writeDepthPng(dir / "wide.png", DepthImage(io::kMaxPngSide, 1, 1.0f), 0.001);
  const DepthImage back = io::readDepthPng(dir / "wide.png", 0.001);
  CHECK(back.width == io::kMaxPngSide);
  CHECK(back.height == 1);
  CHECK_THROWS_AS(io::writeDepthPng(dir / "wider.png", DepthImage(io::kMaxPngSide + 1, 1, 1.0f), 0.001),
                  std::invalid_argument);
}

TEST_CASE("a depth PNG of another size than the camera is refused from its header, naming both sizes",
          "[io][png][hostile]") {
  TempDir dir;
  io::writeDepthPng(dir / "d.png", DepthImage(40, 30, 1.0f), 0.001);
  requireFileErrorMentioning([&] { io::readDepthPng(dir / "d.png", 0.001, 0, 64, 48); },
                             {"d.png", "depth image is 40x30", "the camera is 64x48"});
  CHECK(io::readDepthPng(dir / "d.png", 0.001, 0, 40, 30).width == 40);

  // In a log, a hostile frame is a bad frame (so `--on-bad-frame skip` can skip it).
  writeText(dir / "log" / "sensor.json", R"({"kind": "depth", "width": 4, "height": 3, "fx": 5, "fy": 5, "cx": 2,)"
                                         R"( "cy": 1.5, "depth_scale": 0.001})");
  writeText(dir / "log" / "frames.csv", "timestamp,file,tx,ty,tz,qx,qy,qz,qw\n0.5,depth/huge.png,0,0,0,0,0,0,1\n");
  writeText(dir / "log" / "depth" / "huge.png", hostilePng(100000, 100000));
  const auto source = io::openDataset(dir / "log");
  CHECK_THROWS_AS(source->load(0), io::BadFrameError);
  requireFileErrorMentioning([&] { source->load(0); }, {"frame 0", "huge.png", "100000x100000"});
}

TEST_CASE("a PLY element count beyond the bytes after the header is refused, naming file, element and count",
          "[io][ply][hostile]") {
  TempDir dir;
  const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
  SECTION("binary vertices") {
    writeText(dir / "huge.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n" + xyz +
                                    "end_header\n" + std::string(12, '\0'));
    requireFileErrorMentioning([&] { io::readPointCloud(dir / "huge.ply"); },
                               {"huge.ply", "element 'vertex'", "count 1000000000000", "12 bytes"});
    requireFileErrorMentioning([&] { io::readTriangleMesh(dir / "huge.ply"); },
                               {"huge.ply", "'vertex'", "1000000000000"});
  }
  SECTION("ascii vertices") {
    writeText(dir / "huge.ply", "ply\nformat ascii 1.0\nelement vertex 1000000000000\n" + xyz + "end_header\n0 0 0\n");
    requireFileErrorMentioning([&] { io::readPointCloud(dir / "huge.ply"); },
                               {"huge.ply", "element 'vertex'", "count 1000000000000", "ascii"});
  }
  SECTION("binary faces") {
    writeText(dir / "huge.ply", "ply\nformat binary_big_endian 1.0\nelement vertex 3\n" + xyz +
                                    "element face 1000000000000\nproperty list uchar int vertex_indices\nend_header\n" +
                                    std::string(36, '\0') + "\x03" + std::string(12, '\0'));
    requireFileErrorMentioning([&] { io::readTriangleMesh(dir / "huge.ply"); },
                               {"huge.ply", "element 'face'", "count 1000000000000"});
  }
  SECTION("an element without properties costs no bytes and no time, however many are declared") {
    writeText(dir / "empty.ply", "ply\nformat binary_little_endian 1.0\nelement junk 1000000000000\n"
                                 "element vertex 1\n" + xyz + "end_header\n" + std::string(12, '\0'));
    CHECK(io::readPointCloud(dir / "empty.ply").size() == 1);
  }
}

TEST_CASE("a PCD point count beyond the bytes after the header is refused, naming file, field and count",
          "[io][pcd][hostile]") {
  TempDir dir;
  const std::string head = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  SECTION("binary") {
    writeText(dir / "huge.pcd", head + "WIDTH 1000000000000\nHEIGHT 1\nPOINTS 1000000000000\nDATA binary\n" +
                                    std::string(12, '\0'));
    requireFileErrorMentioning([&] { io::readPointCloud(dir / "huge.pcd"); },
                               {"huge.pcd", "POINTS declares 1000000000000 points", "12 bytes"});
  }
  SECTION("ascii, the count from WIDTH x HEIGHT") {
    writeText(dir / "huge.pcd", head + "WIDTH 1000000\nHEIGHT 1000000\nDATA ascii\n1 2 3\n");
    requireFileErrorMentioning([&] { io::readPointCloud(dir / "huge.pcd"); },
                               {"huge.pcd", "WIDTH x HEIGHT declares 1000000000000 points"});
  }
  SECTION("WIDTH x HEIGHT overflowing") {
    writeText(dir / "huge.pcd", head + "WIDTH 4611686018427387904\nHEIGHT 4\nDATA ascii\n1 2 3\n");
    requireFileErrorMentioning([&] { io::readPointCloud(dir / "huge.pcd"); },
                               {"huge.pcd", "WIDTH", "HEIGHT", "overflows"});
  }
  SECTION("a huge field COUNT") {
    writeText(dir / "huge.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 4611686018427387904\nPOINTS 1\n"
                                "DATA ascii\n1 2 3\n");
    requireFileErrorMentioning([&] { io::readPointCloud(dir / "huge.pcd"); }, {"huge.pcd:4:", "bad COUNT"});
  }
  SECTION("binary_compressed claiming more than LZF can expand to") {
    // 1e8 points of 12 bytes = 1.2 GB of uncompressed data from 4 bytes of LZF.
    writeText(dir / "lzf.pcd", head + "WIDTH 100000000\nHEIGHT 1\nPOINTS 100000000\nDATA binary_compressed\n" +
                                   le32(4) + le32(1200000000u) + std::string(4, '\0'));
    requireFileErrorMentioning([&] { io::readPointCloud(dir / "lzf.pcd"); },
                               {"lzf.pcd", "binary_compressed", "1200000000 bytes", "LZF"});
  }
}

TEST_CASE("OFF vertex and face counts beyond the bytes after them are refused, naming file, line and count",
          "[io][off][hostile]") {
  TempDir dir;
  writeText(dir / "v.off", "OFF\n1000000000000 1 0\n0 0 0\n");
  requireFileErrorMentioning([&] { io::readTriangleMesh(dir / "v.off"); }, {"v.off:2:", "1000000000000 vertices"});
  writeText(dir / "f.off", "OFF 3 1000000000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  requireFileErrorMentioning([&] { io::readTriangleMesh(dir / "f.off"); }, {"f.off:1:", "1000000000000 faces"});
}

TEST_CASE("control bytes quoted from a file are escaped as \\xNN in error messages", "[io][hostile]") {
  TempDir dir;
  const auto requireEscaped = [](const std::function<void()>& fn, const std::string& file, const std::string& shown) {
    const std::string msg = requireFileErrorMentioning(fn, {file, shown});
    CHECK_FALSE(std::any_of(msg.begin(), msg.end(),
                            [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; }));
  };
  writeText(dir / "esc.ply", "ply\nformat ascii 1.0\n\x1b[2Jevil\x7f 1\nend_header\n");
  requireEscaped([&] { io::readPointCloud(dir / "esc.ply"); }, "esc.ply:3:", "'\\x1b[2Jevil\\x7f'");
  writeText(dir / "esc.obj", "v 1 \x07\x08 2\n");
  requireEscaped([&] { io::readTriangleMesh(dir / "esc.obj"); }, "esc.obj:1:", "'\\x07\\x08'");
  writeText(dir / "esc.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 1\nDATA \x1b]0;title\x07\n");
  requireEscaped([&] { io::readPointCloud(dir / "esc.pcd"); }, "esc.pcd:5:", "\\x1b]0;title\\x07");
}

TEST_CASE("a map of a newer format version is refused, naming the file and both versions", "[tsdf][io][hostile]") {
  TempDir dir;
  TsdfVolume().save(dir / "saved.vdb");
  REQUIRE(std::filesystem::exists(TsdfVolume::exactStatePath(dir / "saved.vdb")));
  SECTION("the map") {
    copyWithFormatVersion(dir / "saved.vdb", dir / "map.vdb", 99);
    for (const auto& read : std::initializer_list<std::function<void()>>{
             [&] { TsdfVolume::load(dir / "map.vdb"); }, [&] { readTsdfGrid(dir / "map.vdb"); },
             [&] { inspectMapFile(dir / "map.vdb"); }})
      requireFileErrorMentioning(read, {"map.vdb", "vdbmap_format_version", "99", "newest supported"});
  }
  SECTION("its exact companion") {
    const auto exact = TsdfVolume::exactStatePath(dir / "saved.vdb");
    copyWithFormatVersion(exact, dir / "newer.vdb", 99);
    std::filesystem::rename(dir / "newer.vdb", exact);
    requireFileErrorMentioning([&] { TsdfVolume::load(dir / "saved.vdb"); },
                               {"saved.exact.vdb", "format version 99", "this build reads versions"});
  }
  SECTION("the version this build writes still loads") {
    CHECK_NOTHROW(TsdfVolume::load(dir / "saved.vdb"));
    CHECK_NOTHROW(readTsdfGrid(dir / "saved.vdb"));
    CHECK_NOTHROW(inspectMapFile(dir / "saved.vdb"));
  }
}

TEST_CASE("a truncated map is refused from its declared sizes before OpenVDB reads it, naming what runs past the end",
          "[tsdf][io][hostile]") {
  TempDir dir;
  TsdfVolume volume;
  volume.integrate(0, PointCloud{{0.f, 0.f, 1.f}, {0.1f, 0.f, 1.f}, {0.f, 0.1f, 1.2f}}, Pose3d::Identity());
  volume.save(dir / "saved.vdb");
  const std::string bytes = readBytes(dir / "saved.vdb");
  // 100 bytes: inside the file's metadata (OpenVDB alone took 20 GB of memory on this file).
  // Half: the grids' data are cut off.
  for (const std::size_t keep : {std::size_t(100), bytes.size() / 2}) {
    writeText(dir / "cut.vdb", bytes.substr(0, keep));
    for (const auto& read : std::initializer_list<std::function<void()>>{
             [&] { TsdfVolume::load(dir / "cut.vdb"); }, [&] { readTsdfGrid(dir / "cut.vdb"); },
             [&] { inspectMapFile(dir / "cut.vdb"); }, [&] { TsdfVolume::savedUnitId(dir / "cut.vdb"); }})
      requireFileErrorMentioning(read, {"cut.vdb", "truncated or damaged"});
  }
  // A cut companion: load names it; info reports it unusable.
  writeText(TsdfVolume::exactStatePath(dir / "saved.vdb"),
            readBytes(TsdfVolume::exactStatePath(dir / "saved.vdb")).substr(0, 300));
  requireFileErrorMentioning([&] { TsdfVolume::load(dir / "saved.vdb"); }, {"saved.exact.vdb", "truncated or damaged"});
  CHECK_FALSE(inspectMapFile(dir / "saved.vdb").has_exact_state);
  CHECK_THAT(inspectMapFile(dir / "saved.vdb").exact_state_problem, Catch::Contains("saved.exact.vdb"));
}

namespace {
/// Sets each byte of `file` in turn to 0xff (0x00 where it is 0xff), runs `read` on the damaged
/// file and restores it. Every read must succeed or throw a FileError naming `file`; returns how
/// many messages held `fragment`.
std::size_t damageEachByte(const std::filesystem::path& file, const std::function<void()>& read,
                           const std::string& fragment) {
  const std::string bytes = readBytes(file);
  std::size_t matched = 0;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    std::string damaged = bytes;
    damaged[i] = damaged[i] == char(0xff) ? char(0) : char(0xff);
    writeText(file, damaged);
    try {
      read();
    } catch (const FileError& e) {
      INFO("byte " << i << " of " << file);
      CHECK_THAT(e.what(), Catch::Contains(file.filename().string()));
      if (std::string(e.what()).find(fragment) != std::string::npos) ++matched;
    }
  }
  writeText(file, bytes);
  return matched;
}
}  // namespace

TEST_CASE("a saved map with any one byte damaged loads or is refused naming the file, its trees walked first",
          "[tsdf][io][hostile]") {
  // OpenVDB alone read a damaged grid past its end and allocated from the uninitialised chunk size
  // it read there (fuzz/regressions/fuzz_vdb/grid-data-overrun-*.vdb). Other exceptions, crashes
  // and sanitizer reports fail this test.
  TempDir dir;
  TsdfVolume volume;
  volume.integrate(0, PointCloud{{0.f, 0.f, 0.4f}}, Pose3d::Identity());
  volume.save(dir / "saved.vdb");
  const auto readAll = [&] {
    TsdfVolume::load(dir / "saved.vdb");
    readTsdfGrid(dir / "saved.vdb");
    inspectMapFile(dir / "saved.vdb");
  };
  SECTION("the exact companion (int64 trees)") {
    CHECK(damageEachByte(TsdfVolume::exactStatePath(dir / "saved.vdb"), readAll, " leaf ") > 0);
  }
  SECTION("the map alone (float trees)") {
    std::filesystem::remove(TsdfVolume::exactStatePath(dir / "saved.vdb"));
    CHECK(damageEachByte(dir / "saved.vdb", readAll, " leaf ") > 0);
  }
}

TEST_CASE("float sums with a non-finite or huge weight are refused naming the voxel, before any overflow",
          "[tsdf][hostile]") {
  const TsdfConfig config;
  for (const float bad_weight : {std::nanf(""), std::numeric_limits<float>::infinity(), 1e30f}) {
    openvdb::FloatGrid weight, weighted;
    weight.tree().setValue(openvdb::Coord(1, 2, 3), 1.f);
    weight.tree().setValue(openvdb::Coord(4, 5, 6), bad_weight);
    weighted.tree().setValue(openvdb::Coord(4, 5, 6), 0.f);
    CHECK_THROWS_WITH(TsdfVolume::fromWeightedSums(config, IntegratorConfig(), weight, weighted),
                      Catch::Contains("[4, 5, 6]") && Catch::Contains("at most 2^30"));
  }
  openvdb::FloatGrid weight, weighted;
  weight.tree().setValue(openvdb::Coord(0, 0, 0), 2.f);
  weighted.tree().setValue(openvdb::Coord(0, 0, 0), std::numeric_limits<float>::infinity());
  CHECK_THROWS_WITH(TsdfVolume::fromWeightedSums(config, IntegratorConfig(), weight, weighted),
                    Catch::Contains("[0, 0, 0]") && Catch::Contains("weighted tsdf inf"));
}

TEST_CASE("a ground-truth mesh with a NaN or far vertex is refused naming the vertex, before sampling",
          "[eval][hostile]") {
  TriangleMesh mesh;
  mesh.vertices = {Vec3f(0.f, 0.f, 0.f), Vec3f(std::nanf(""), 0.f, 0.f), Vec3f(0.f, 1.f, 0.f)};
  mesh.triangles = {Eigen::Vector3i(0, 1, 2)};
  CHECK_THROWS_WITH(SurfaceDistance(mesh, 0.01), Catch::Contains("vertex 1") && Catch::Contains("not finite"));
  mesh.vertices[1] = Vec3f(1e9f, 0.f, 0.f);
  CHECK_THROWS_WITH(SurfaceDistance(mesh, 0.01), Catch::Contains("vertex 1"));
  // A large triangle at a fine spacing: the sample count is bounded before any is drawn.
  mesh.vertices[1] = Vec3f(1e4f, 0.f, 0.f);
  mesh.vertices[2] = Vec3f(0.f, 1e4f, 0.f);
  CHECK_THROWS_WITH(SurfaceDistance(mesh, 0.01), Catch::Contains("samples") && Catch::Contains("coarser spacing"));
}

TEST_CASE("writing over a folder says it is a folder and leaves nothing behind", "[io][atomic][hostile]") {
  TempDir dir;
  std::filesystem::create_directories(dir / "out.vdb");
  std::filesystem::create_directories(dir / "cloud.ply");
  requireFileErrorMentioning([&] { TsdfVolume().save(dir / "out.vdb"); }, {"out.vdb", "is a folder"});
  CHECK_FALSE(std::filesystem::exists(TsdfVolume::exactStatePath(dir / "out.vdb")));
  requireFileErrorMentioning([&] { io::writePointCloud(dir / "cloud.ply", {Vec3f(1.f, 2.f, 3.f)}); },
                             {"cloud.ply", "is a folder"});
  requireFileErrorMentioning([&] { writeFileAtomically(dir / "out.vdb", [](std::ostream& out) { out << "x"; }); },
                             {"out.vdb", "is a folder"});

  // The commit step too, and a failed rename gives its real reason, never "Success".
  const auto tmp = temporaryPathFor(dir / "out.vdb");
  writeText(tmp, "x");
  requireFileErrorMentioning([&] { commitTemporary(tmp, dir / "out.vdb"); }, {"out.vdb", "is a folder"});
  CHECK_FALSE(std::filesystem::exists(tmp));
  bool thrown = false;
  try {
    commitTemporary(dir / "no_such_tmp", dir / "target.bin");
  } catch (const FileError& e) {
    thrown = true;
    const std::string msg = e.what();
    INFO("message: " << msg);
    CHECK(msg.find("target.bin") != std::string::npos);
    CHECK(msg.find("No such file") != std::string::npos);
    CHECK(msg.find("Success") == std::string::npos);
  }
  CHECK(thrown);
  for (const auto& entry : std::filesystem::directory_iterator(dir.path()))
    CHECK(entry.path().filename().string().find(".tmp.") == std::string::npos);
}

TEST_CASE("a process stopped by a signal during a write removes its temporary and dies of that signal",
          "[io][atomic][hostile]") {
  TempDir dir;
  for (int sig : {SIGINT, SIGTERM}) {
    const std::filesystem::path target = dir / ("out" + std::to_string(sig) + ".bin");
    writeText(target, "the previous content");
    const pid_t child = ::fork();
    REQUIRE(child >= 0);
    if (child == 0) {  // the child: a write in progress when the signal arrives
      removeTemporariesOnSignals();
      const std::filesystem::path tmp = temporaryPathFor(target);
      writeText(tmp, "half a file");
      std::raise(sig);
      std::_Exit(3);  // not reached: the handler ends the process by the signal
    }
    int status = 0;
    REQUIRE(::waitpid(child, &status, 0) == child);
    CHECK(WIFSIGNALED(status));
    CHECK(WTERMSIG(status) == sig);
    CHECK(readBytes(target) == "the previous content");
    for (const auto& entry : std::filesystem::directory_iterator(dir.path()))
      CHECK(entry.path().filename().string().find(".tmp.") == std::string::npos);
  }
}

TEST_CASE("a depth image not of the camera's size is refused by each reader of it, naming who and both sizes",
          "[camera][hostile]") {
  auto K = std::make_shared<CameraIntrinsics>();  // 640 x 480
  const DepthImage small(320, 240, 1.0f);
  // (Catch2 v2 matchers combined with && hold references: each is written where it is used.)
  CHECK_THROWS_WITH(backProject(small, *K),
                    Catch::Contains("backProject") && Catch::Contains("320x240") && Catch::Contains("640x480"));
  CHECK_THROWS_WITH(EncodedFrame::fromDepth(small, K), Catch::Contains("EncodedFrame::fromDepth") &&
                                                           Catch::Contains("320x240") && Catch::Contains("640x480"));
  // The right width and height over too few pixels (a truncated buffer) is refused, not read past.
  DepthImage truncated(K->width, K->height, 1.0f);
  truncated.depth_m.resize(truncated.depth_m.size() / 2);
  CHECK_THROWS_WITH(backProject(truncated, *K), Catch::Contains("backProject") && Catch::Contains("640x480"));
  CHECK_THROWS_AS(EncodedFrame::fromDepth(truncated, K), std::invalid_argument);
}

TEST_CASE("a voxel size far too small for a frame is refused before any work, naming the memory estimate",
          "[tsdf][hostile]") {
  // 0.1 mm voxels and rays of up to 4 m: about 10^13 bytes of leaves by the estimate, more than any
  // machine this runs on. The frame is refused before a voxel is written.
  CameraIntrinsics K;  // 640 x 480
  TsdfConfig config;
  config.voxel_size_m = 1e-4;
  TsdfVolume volume(config);
  const DepthImage depth(K.width, K.height, 4.0f);
  CHECK_THROWS_WITH(volume.integrate(7, depth, K, Pose3d::Identity()),
                    Catch::Contains("frame 7") && Catch::Contains("GB of map memory") && Catch::Contains("voxel size"));
  CHECK_THROWS_WITH(volume.integrate(8, backProject(depth, K), Pose3d::Identity()),
                    Catch::Contains("frame 8") && Catch::Contains("GB of map memory"));
  CHECK(volume.activeVoxelCount() == 0);
  CHECK(volume.frameCount() == 0);
  // Four points 12 cm away fit at that voxel size and are integrated.
  volume.integrate(9, PointCloud{{0.f, 0.f, 0.12f}, {0.01f, 0.f, 0.12f}, {0.f, 0.01f, 0.12f}, {0.01f, 0.01f, 0.12f}},
                   Pose3d::Identity());
  CHECK(volume.activeVoxelCount() > 0);
}

TEST_CASE("a pose far beyond the range of the map is refused before any work and names the frame",
          "[tsdf][mapper][hostile]") {
  const CameraIntrinsics K = test::pinholeCamera(16, 12, 10.0, 7.5, 5.5);
  const DepthImage depth(K.width, K.height, 2.0f);
  TsdfConfig config;
  config.voxel_size_m = 0.05;
  TsdfVolume volume(config);
  Pose3d far = Pose3d::Identity();
  far.translation() = Vec3d(1e9, 0.0, 0.0);
  CHECK_THROWS_WITH(volume.integrate(3, depth, K, far), Catch::Contains("frame 3") && Catch::Contains("outside the map's range"));
  CHECK(volume.activeVoxelCount() == 0);
  CHECK_FALSE(volume.isIntegrated(3));
  // A correction that far is refused too, and the frame stays where it is.
  volume.integrate(3, depth, K, Pose3d::Identity());
  const std::size_t voxels = volume.activeVoxelCount();
  CHECK_THROWS_WITH(volume.reintegrate(3, depth, K, Pose3d::Identity(), far),
                    Catch::Contains("frame 3") && Catch::Contains("range"));
  CHECK(volume.activeVoxelCount() == voxels);
  // Points, the same.
  CHECK_THROWS_WITH(volume.integrate(4, backProject(depth, K), far), Catch::Contains("frame 4") && Catch::Contains("range"));

  // Within the map's range but beyond what frame pruning packs (2^20 cells of 1 cm here): refused
  // by the keyframes mapper before the map or its store change, for a new frame and a correction.
  MapperConfig keyframes;
  keyframes.mode = ConsistencyMode::Keyframes;
  keyframes.tsdf.voxel_size_m = 0.01;
  keyframes.set_cover.cell_size_vox = 1.0;
  Mapper mapper(keyframes);
  Pose3d beyond_cells = Pose3d::Identity();
  beyond_cells.translation() = Vec3d(0.0, 20000.0, 0.0);
  const auto camera = std::make_shared<const CameraIntrinsics>(K);
  CHECK_THROWS_WITH(mapper.addFrame(5, 0.0, SensorFrame::depth(depth, camera), beyond_cells),
                    Catch::Contains("frame 5") && Catch::Contains("frame pruning"));
  CHECK(mapper.volume().frameCount() == 0);
  CHECK(mapper.keyframes().size() == 0);
  mapper.addFrame(6, 0.1, SensorFrame::depth(depth, camera), Pose3d::Identity());
  CHECK_THROWS_WITH(mapper.updatePoses({{6, beyond_cells}}), Catch::Contains("frame 6") && Catch::Contains("frame pruning"));
  CHECK(mapper.queuedFrames() == 0);
}
