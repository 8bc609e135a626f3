// The hostile inputs of data/hostile (make_hostile.py there): each is at most a few hundred bytes,
// and `vdbmap` must refuse it at once with exit status 1, a message naming the file (and the frame,
// line or field) and what is wrong, without a large allocation (the child's peak resident memory
// stays near the program's own), and without replacing a good map.
#include "cli_test_util.hpp"

#include <catch2/catch.hpp>

#include <sys/resource.h>

#include <filesystem>
#include <initializer_list>
#include <string>

namespace fs = std::filesystem;
using vdbmap::test::runCli;
using vdbmap::test::slurp;

namespace {

const fs::path kHostile = fs::path(VDBMAP_SOURCE_DIR) / "data" / "hostile";
/// The program itself takes about 60 MB; a hostile file may not add more than this.
constexpr long kMaxPeakKib = 300 * 1024;

/// Runs `vdbmap ARGS`; checks exit status 1, every fragment in the output, and the peak memory of
/// the children so far (each Catch test case runs in a process of its own under CTest).
void requireRefused(const std::string& args, const fs::path& out, std::initializer_list<const char*> fragments) {
  INFO("vdbmap " << args);
  const int status = runCli(args, out);
  const std::string text = slurp(out);
  INFO("output:\n" << text);
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 1);
  for (const char* f : fragments) CHECK_THAT(text, Catch::Contains(f));
  rusage usage{};
  REQUIRE(getrusage(RUSAGE_CHILDREN, &usage) == 0);
  CHECK(usage.ru_maxrss < kMaxPeakKib);
}

fs::path freshOut(const std::string& name) { return vdbmap::test::freshDir("vdbmap_cli_hostile_" + name); }

}  // namespace

TEST_CASE("vdbmap refuses a pose of 1e9 m before any work, naming the frame", "[cli][hostile]") {
  const fs::path dir = freshOut("pose");
  requireRefused("integrate " + (kHostile / "far_pose_log").string() + " -o " + (dir / "m.vdb").string(),
                 dir / "out.txt", {"frame 0", "1e+09", "range"});
  CHECK_FALSE(fs::exists(dir / "m.vdb"));
}

TEST_CASE("vdbmap refuses sizes declared by headers before allocating them, naming file and count",
          "[cli][hostile]") {
  const fs::path dir = freshOut("headers");
  requireRefused("integrate " + (kHostile / "huge_png_log").string() + " -o " + (dir / "m.vdb").string(),
                 dir / "out.txt", {"000000.png", "100000x100000", "frames.csv:2"});
  requireRefused("integrate " + (kHostile / "points_huge_pcd_log").string() + " -o " + (dir / "m.vdb").string(),
                 dir / "out.txt", {"huge_point_count.pcd", "1000000000000"});
  requireRefused("atsp " + (kHostile / "dimension_20000.atsp").string(), dir / "out.txt",
                 {"dimension_20000.atsp", "DIMENSION 20000"});
  requireRefused("info " + (kHostile / "cut_map.vdb").string(), dir / "out.txt",
                 {"cut_map.vdb", "metadata entries", "truncated or damaged"});
  requireRefused("mesh " + (kHostile / "cut_map.vdb").string() + " -o " + (dir / "m.ply").string(), dir / "out.txt",
                 {"cut_map.vdb", "truncated or damaged"});
  // Ground truth for eval: a map to compare with first.
  REQUIRE(runCli("integrate " + (kHostile / "valid_log").string() + " -o " + (dir / "good.vdb").string(),
                 dir / "out.txt") == 0);
  requireRefused("eval " + (dir / "good.vdb").string() + " --gt " + (kHostile / "huge_vertex_count.ply").string(),
                 dir / "out.txt", {"huge_vertex_count.ply", "vertex", "1000000000000"});
  requireRefused("eval " + (dir / "good.vdb").string() + " --gt " + (kHostile / "nan_vertex.ply").string(),
                 dir / "out.txt", {"vertex 1", "not finite"});
  // A voxel size far too fine for the frame: refused by its memory estimate.
  requireRefused("integrate " + (kHostile / "wide_frame_log").string() + " -o " + (dir / "fine.vdb").string() +
                     " --voxel-size 1e-4",
                 dir / "out.txt", {"frame 0", "GB of map memory", "voxel size"});
}

TEST_CASE("vdbmap never replaces a good map with a failed or empty one, and refuses a companion's name",
          "[cli][hostile]") {
  const fs::path dir = freshOut("outputs");
  REQUIRE(runCli("integrate " + (kHostile / "valid_log").string() + " -o " + (dir / "m.vdb").string(),
                 dir / "out.txt") == 0);
  const std::string good = slurp(dir / "m.vdb");
  requireRefused("integrate " + (kHostile / "header_only_log").string() + " -o " + (dir / "m.vdb").string(),
                 dir / "out.txt", {"no frame was integrated", "nothing written"});
  requireRefused("integrate " + (kHostile / "far_pose_log").string() + " -o " + (dir / "m.vdb").string(),
                 dir / "out.txt", {"frame 0"});
  CHECK(slurp(dir / "m.vdb") == good);
  requireRefused("integrate " + (kHostile / "valid_log").string() + " -o " + (dir / "x.exact.vdb").string(),
                 dir / "out.txt", {"x.exact.vdb", "companion"});
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    CHECK_THAT(name, !Catch::Contains(".tmp.") && !Catch::StartsWith("x."));
  }
}

TEST_CASE("vdbmap messages: short numbers, escaped control bytes, and what the docs forbid", "[cli][hostile]") {
  const fs::path dir = freshOut("messages");
  requireRefused("integrate " + (kHostile / "dbl_max_scale_log").string() + " -o " + (dir / "m.vdb").string(),
                 dir / "out.txt", {"sensor.json", "depth_scale", "1.79769e+308"});
  CHECK(slurp(dir / "out.txt").size() < 400);
  requireRefused("integrate " + (kHostile / "control_bytes_log").string() + " -o " + (dir / "m.vdb").string(),
                 dir / "out.txt", {"frames.csv:2", "\\x1b[31mred.png", "no such file"});
  CHECK_THAT(slurp(dir / "out.txt"), !Catch::Contains("\x1b"));
  requireRefused("integrate " + (kHostile / "extra_column_log").string() + " -o " + (dir / "m.vdb").string(),
                 dir / "out.txt", {"frames.csv:2", "9 comma-separated", "found 10"});
  requireRefused("integrate " + (kHostile / "negative_fx_log").string() + " -o " + (dir / "m.vdb").string(),
                 dir / "out.txt", {"sensor.json", "fx"});
}
