// `vdbmap bench alc` runs both arms per world and seed and writes alc.json (one object per run, the
// keys the issue lists), alc.md and each run's summary.json; bad arguments fail.
#include "tools/cli_test_worlds.hpp"

#include "vdbmap/io/mesh_io.hpp"

#include "tools/cli_test_util.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

namespace fs = std::filesystem;

namespace {
int run(const std::string& args, const fs::path& out_file) { return vdbmap::test::runCli(args, out_file); }
using vdbmap::test::slurp;
}  // namespace

TEST_CASE("vdbmap bench alc writes alc.json and alc.md with both arms per seed", "[cli][bench][alc]") {
  const fs::path dir = fs::temp_directory_path() / "vdbmap_cli_bench_alc";
  fs::remove_all(dir);
  fs::create_directories(dir);
  vdbmap::io::writePlyMesh(dir / "room.ply", vdbmap::test::roomWithBox());
  const fs::path bench = dir / "bench", out = dir / "out.txt";
  const std::string world = " --world " + (dir / "room.ply").string();
  REQUIRE(run("bench alc" + world + " --drift s3 --seeds 1 --max-time-s 30 --epsilon 0.3 -o " + bench.string(), out) ==
          0);
  INFO(slurp(out));
  const auto runs = nlohmann::json::parse(slurp(bench / "alc.json"));
  REQUIRE(runs.is_array());
  REQUIRE(runs.size() == 2);
  std::set<std::string> arms;
  for (const auto& r : runs) {
    for (const char* key : {"arm", "seed", "exploration_time_s", "loop_closures", "accuracy_rmse_m", "completeness",
                            "finished", "coverage", "coverage_seen", "alc_detours", "alc_time_s", "collisions"})
      CHECK(r.contains(key));
    CHECK(r.at("seed") == 1);
    CHECK(r.at("exploration_time_s").get<double>() > 0.0);
    CHECK(r.at("exploration_time_s").get<double>() <= 30.0 + 1e-6);
    CHECK(r.at("accuracy_rmse_m").get<double>() > 0.0);
    arms.insert(r.at("arm").get<std::string>());
    // The run's own summary says which arm it was.
    CHECK(r.at("world") == "room");
    const fs::path run_dir = bench / "runs" / "room" / (r.at("arm").get<std::string>() + "_seed1");
    const auto s = nlohmann::json::parse(slurp(run_dir / "summary.json"));
    CHECK(s.at("alc_enabled") == (r.at("arm") == "alc"));
    if (r.at("arm") == "alc") CHECK(s.at("epsilon").get<double>() == Approx(0.3));
    if (r.at("arm") == "no_alc") CHECK(r.at("alc_detours") == 0);
    CHECK_FALSE(fs::exists(run_dir / "log"));  // logs and maps only with --keep-runs
    CHECK_FALSE(fs::exists(run_dir / "map.vdb"));
  }
  CHECK(arms == std::set<std::string>{"alc", "no_alc"});
  const std::string md = slurp(bench / "alc.md");
  for (const char* text : {"no_alc", "| alc |", "time overhead", "loop-closure gain", "exploration time (s)"})
    CHECK(md.find(text) != std::string::npos);
  CHECK(slurp(out).find("time overhead") != std::string::npos);  // the table is printed too

  // Several worlds: each gets its runs and its row, and the effect is pooled over all pairs.
  vdbmap::io::writePlyMesh(dir / "room2.ply", vdbmap::test::roomWithBox());
  const fs::path multi = dir / "multi";
  REQUIRE(run("bench alc --worlds " + (dir / "room.ply").string() + " " + (dir / "room2.ply").string() +
                  " --seeds 1 --max-time-s 10 --safety on --safety-seen-free on --jobs 3 -o " + multi.string(),
              out) == 0);
  const auto multi_runs = nlohmann::json::parse(slurp(multi / "alc.json"));
  REQUIRE(multi_runs.size() == 4);
  // Three runs at a time: the table lists them per world, per seed, no_alc then alc all the same.
  for (std::size_t k = 0; k < 4; ++k) {
    CHECK(multi_runs[k].at("world") == (k < 2 ? "room" : "room2"));
    CHECK(multi_runs[k].at("arm") == (k % 2 == 0 ? "no_alc" : "alc"));
  }
  std::set<std::string> worlds;
  for (const auto& r : multi_runs) {
    worlds.insert(r.at("world").get<std::string>());
    const fs::path summary = multi / "runs" / r.at("world").get<std::string>() /
                             (r.at("arm").get<std::string>() + "_seed1") / "summary.json";
    REQUIRE(fs::exists(summary));
    const auto run_summary = nlohmann::json::parse(slurp(summary));
    CHECK(run_summary.at("safety_layer") == true);
    CHECK(run_summary.at("safety_vertical_margin_m") == 0.2);  // s3 drifts: the margin holds
    // and grows with the time flown, to 2 sigmas of s3's vertical drift (at least the 0.2 m).
    const double flown_s = run_summary.at("exploration_time_s").get<double>();
    CHECK(run_summary.at("safety_vertical_margin_end_m").get<double>() ==
          Approx(std::clamp(2.0 * std::sqrt(5e-2 / 200.0 * flown_s), 0.2, 0.3)));
  }
  CHECK(worlds == std::set<std::string>{"room", "room2"});
  const std::string multi_md = slurp(multi / "alc.md");
  CHECK(multi_md.find("2 pairs") != std::string::npos);
  CHECK(multi_md.find("| room2 | 1 |") != std::string::npos);
  CHECK(multi_md.find(
            "Safety layer on (seen free is free) (no thin structure from the map) (vertical margin 0.20-0.30 m)") !=
        std::string::npos);
  CHECK(run("bench alc --world " + (dir / "room.ply").string() + " --worlds " + (dir / "room2.ply").string() + " -o " +
                (dir / "x").string(),
            out) != 0);  // one or the other
  CHECK(run("bench alc --worlds office:5-1 -o " + (dir / "x").string(), out) != 0);
  CHECK(slurp(out).find("office:5-1") != std::string::npos);

  CHECK(run("bench alc" + world + " --seeds 0 -o " + (dir / "x").string(), out) != 0);
  CHECK(run("bench alc" + world + " --drift s9 -o " + (dir / "x").string(), out) != 0);
  CHECK(run("bench alc --world " + (dir / "missing.ply").string() + " -o " + (dir / "x").string(), out) != 0);
  fs::remove_all(dir);
}

TEST_CASE("vdbmap bench alc --resume keeps the runs an earlier call made and refuses runs made otherwise",
          "[cli][bench][alc][resume]") {
  const fs::path dir = fs::temp_directory_path() / "vdbmap_cli_bench_alc_resume";
  fs::remove_all(dir);
  fs::create_directories(dir);
  vdbmap::io::writePlyMesh(dir / "room.ply", vdbmap::test::roomWithBox());
  const fs::path bench = dir / "bench", out = dir / "out.txt";
  const std::string args =
      "bench alc --world " + (dir / "room.ply").string() + " --drift s3 --max-time-s 10 -o " + bench.string();
  REQUIRE(run(args + " --seeds 1", out) == 0);
  const auto first = nlohmann::json::parse(slurp(bench / "alc.json"));
  REQUIRE(first.size() == 2);

  // Seed 2 added: seed 1's runs are kept as they were (their wall time too, so not flown again).
  REQUIRE(run(args + " --seeds 2 --resume", out) == 0);
  CHECK(slurp(out).find("kept 2 of 4 runs") != std::string::npos);
  const auto resumed = nlohmann::json::parse(slurp(bench / "alc.json"));
  REQUIRE(resumed.size() == 4);
  CHECK(resumed[0] == first[0]);
  CHECK(resumed[1] == first[1]);
  for (std::size_t k = 2; k < 4; ++k) {
    CHECK(resumed[k].at("seed") == 2);
    CHECK(resumed[k].at("arm") == (k == 2 ? "no_alc" : "alc"));
  }
  CHECK(slurp(bench / "alc.md").find("| room | 2 | alc |") != std::string::npos);
  CHECK(slurp(bench / "alc.md").find("2 runs were kept from an earlier call") != std::string::npos);

  // Without --resume every run is flown again (the wall time of a run never repeats exactly).
  REQUIRE(run(args + " --seeds 1", out) == 0);
  const auto again = nlohmann::json::parse(slurp(bench / "alc.json"));
  REQUIRE(again.size() == 2);
  CHECK(again[0].at("wall_s") != first[0].at("wall_s"));
  CHECK(again[0].at("exploration_time_s") == first[0].at("exploration_time_s"));  // the same flight

  // A run made with other options is never mixed in: the error names the file and the option.
  CHECK(run(args + " --seeds 1 --epsilon 0.7 --resume", out) != 0);
  CHECK(slurp(out).find("alc_seed1/summary.json was run with epsilon") != std::string::npos);
  CHECK(run(args + " --seeds 1 --safety on --resume", out) != 0);
  CHECK(slurp(out).find("was run with safety_") != std::string::npos);
  CHECK(run(args + " --seeds 1 --ceiling 2 --resume", out) != 0);  // the same file cut elsewhere
  CHECK(slurp(out).find("was run with world_ceiling") != std::string::npos);
  // A damaged summary names its file and the key it lacks.
  const fs::path summary = bench / "runs" / "room" / "no_alc_seed1" / "summary.json";
  auto damaged = nlohmann::json::parse(slurp(summary));
  damaged.erase("coverage");
  std::ofstream(summary) << damaged.dump(2);
  CHECK(run(args + " --seeds 1 --resume", out) != 0);
  CHECK(slurp(out).find("no_alc_seed1/summary.json: no \"coverage\"") != std::string::npos);
  fs::remove_all(dir);
}
