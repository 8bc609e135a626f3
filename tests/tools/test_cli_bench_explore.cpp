// `vdbmap bench explore` explores every world for every seed and tabulates how coverage grew;
// `vdbmap world office` writes a generated world it can fly; bad arguments fail naming them.
#include "tools/cli_test_worlds.hpp"

#include "vdbmap/io/mesh_io.hpp"

#include "tools/cli_test_util.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

namespace fs = std::filesystem;

namespace {
int run(const std::string& args, const fs::path& out_file) { return vdbmap::test::runCli(args, out_file); }
using vdbmap::test::slurp;
}  // namespace

TEST_CASE("vdbmap bench explore tabulates time to coverage per world and seed", "[cli][bench][explore]") {
  const fs::path dir = vdbmap::test::freshDir("vdbmap_cli_bench_explore");
  vdbmap::io::writePlyMesh(dir / "room.ply", vdbmap::test::roomWithBox());
  const fs::path bench = dir / "bench", out = dir / "out.txt";
  REQUIRE(run("bench explore --worlds " + (dir / "room.ply").string() + " --ceiling 0 --seeds 2 --max-time-s 40 -o " +
                  bench.string(),
              out) == 0);
  INFO(slurp(out));
  const auto runs = nlohmann::json::parse(slurp(bench / "explore.json"));
  REQUIRE(runs.size() == 2);
  for (std::size_t k = 0; k < 2; ++k) {
    const auto& r = runs[k];
    CHECK(r.at("world") == "room");
    CHECK(r.at("seed") == k + 1);
    const fs::path run_dir = bench / "runs" / ("room_seed" + std::to_string(k + 1));
    const auto s = nlohmann::json::parse(slurp(run_dir / "summary.json"));
    // The table's figures are the run's own.
    CHECK(r.at("exploration_time_s") == s.at("exploration_time_s"));
    CHECK(r.at("time_to_coverage_s") == s.at("time_to_coverage_s"));
    CHECK(r.at("mean_speed_mps") == s.at("mean_speed_mps"));
    CHECK(r.at("complete") == s.at("complete"));
    CHECK(fs::exists(run_dir / "coverage.csv"));
    CHECK(r.at("real_time_factor").get<double>() > 0.0);
  }
  const std::string md = slurp(bench / "explore.md");
  for (const char* text : {"## Per world", "| room | 2 |", "t95", "final sweep", "real-time factor", "| complete |"})
    CHECK(md.find(text) != std::string::npos);
  // The complete column counts the runs summary.json calls complete.
  std::size_t finished = 0, complete = 0;
  for (const auto& r : runs) {
    finished += r.at("finished").get<bool>();
    complete += r.at("complete").get<bool>();
  }
  CHECK(md.find("| room | 2 | " + std::to_string(finished) + " | " + std::to_string(complete) + " |") !=
        std::string::npos);

  // Two runs at a time fly the same runs and list them in the same order: a run's budgets are
  // counted, not timed, so nothing it does depends on what runs beside it.
  const fs::path concurrent = dir / "concurrent";
  REQUIRE(run("bench explore --worlds " + (dir / "room.ply").string() +
                  " --ceiling 0 --seeds 2 --max-time-s 40 --jobs 2 -o " + concurrent.string(),
              out) == 0);
  const auto concurrent_runs = nlohmann::json::parse(slurp(concurrent / "explore.json"));
  REQUIRE(concurrent_runs.size() == runs.size());
  for (std::size_t k = 0; k < runs.size(); ++k) {
    CHECK(concurrent_runs[k].at("seed") == runs[k].at("seed"));
    for (const char* key : {"exploration_time_s", "path_length_m", "coverage", "time_to_coverage_s", "collisions"})
      CHECK(concurrent_runs[k].at(key) == runs[k].at(key));
    const fs::path name = fs::path("runs") / ("room_seed" + std::to_string(k + 1)) / "trajectory_true.txt";
    CHECK(slurp(concurrent / name) == slurp(bench / name));
  }
  // Two worlds, two seeds, started seed by seed across the worlds: the table stays per world, per seed.
  vdbmap::io::writePlyMesh(dir / "room2.ply", vdbmap::test::roomWithBox());
  const fs::path two = dir / "two";
  REQUIRE(run("bench explore --worlds " + (dir / "room.ply").string() + " " + (dir / "room2.ply").string() +
                  " --ceiling 0 --seeds 2 --max-time-s 5 --jobs 2 -o " + two.string(),
              out) == 0);
  const auto two_runs = nlohmann::json::parse(slurp(two / "explore.json"));
  REQUIRE(two_runs.size() == 4);
  for (std::size_t k = 0; k < 4; ++k) {
    CHECK(two_runs[k].at("world") == (k < 2 ? "room" : "room2"));
    CHECK(two_runs[k].at("seed") == k % 2 + 1);
  }
  // Resumed with a third seed: the four runs made are kept as they were, only seed 3 is flown.
  REQUIRE(run("bench explore --worlds " + (dir / "room.ply").string() + " " + (dir / "room2.ply").string() +
                  " --ceiling 0 --seeds 3 --max-time-s 5 --jobs 2 --resume -o " + two.string(),
              out) == 0);
  CHECK(slurp(out).find("kept 4 of 6 runs") != std::string::npos);
  const auto resumed = nlohmann::json::parse(slurp(two / "explore.json"));
  REQUIRE(resumed.size() == 6);
  for (std::size_t k = 0; k < 6; ++k) {
    CHECK(resumed[k].at("world") == (k < 3 ? "room" : "room2"));
    CHECK(resumed[k].at("seed") == k % 3 + 1);
    if (k % 3 < 2) CHECK(resumed[k] == two_runs[k < 3 ? k : k - 1]);
  }
  CHECK(run("bench explore --worlds " + (dir / "room.ply").string() +
                " --ceiling 0 --seeds 1 --max-time-s 6 "
                "--resume -o " +
                two.string(),
            out) != 0);  // another time limit
  CHECK(slurp(out).find("was run with max_time_s = 5.0 but this benchmark asks for 6.0") != std::string::npos);
  CHECK(run("bench explore --worlds office:1 --jobs 0 -o " + (dir / "x").string(), out) != 0);
  CHECK(slurp(out).find("--jobs") != std::string::npos);

  // A generated office is written beside the runs (a report colours maps by it); its spec is checked.
  CHECK(run("bench explore --worlds office:0 -o " + (dir / "x").string(), out) != 0);
  CHECK(slurp(out).find("office:0") != std::string::npos);
  CHECK(run("bench explore --worlds office:2:20by16 -o " + (dir / "x").string(), out) != 0);
  CHECK(slurp(out).find("XxY") != std::string::npos);
  CHECK(run("bench explore --worlds office:2:9x9 -o " + (dir / "x").string(), out) != 0);
  CHECK(slurp(out).find("size_y_m") != std::string::npos);
}

TEST_CASE("vdbmap world office writes the same mesh for the same seed", "[cli][world]") {
  const fs::path dir = vdbmap::test::freshDir("vdbmap_cli_world");
  const fs::path out = dir / "out.txt";
  REQUIRE(run("world office --seed 7 --size 20,14 -o " + (dir / "a.ply").string(), out) == 0);
  CHECK(slurp(out).find("rooms") != std::string::npos);
  REQUIRE(run("world office --seed 7 --size 20,14 -o " + (dir / "b.ply").string(), out) == 0);
  CHECK(slurp(dir / "a.ply") == slurp(dir / "b.ply"));
  const vdbmap::TriangleMesh mesh = vdbmap::io::readTriangleMesh(dir / "a.ply");
  CHECK(mesh.triangles.size() > 100);
  CHECK(run("world office --size 20,5 -o " + (dir / "c.ply").string(), out) != 0);
  CHECK(slurp(out).find("size_y_m") != std::string::npos);
}
