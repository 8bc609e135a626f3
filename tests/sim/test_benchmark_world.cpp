// Benchmark world specs: mesh files keep their cut, office seeds and ranges expand to one world
// each with unique names, malformed specs are named; and the ALC benchmark's tables pair the arms
// by world and seed (overhead, RMSE wins, incomplete runs) as the summaries say.
#include "vdbmap/sim/alc_benchmark.hpp"
#include "vdbmap/sim/benchmark_world.hpp"

#include <catch2/catch.hpp>

#include <string>

using namespace vdbmap;
using sim::BenchmarkWorld;
using sim::parseBenchmarkWorlds;

TEST_CASE("benchmark world specs: a mesh file, one office, a range of offices", "[sim][bench]") {
  const std::vector<BenchmarkWorld> mesh = parseBenchmarkWorlds("/data/worlds/warehouse.ply", 2.5);
  REQUIRE(mesh.size() == 1);
  CHECK(mesh[0].name == "warehouse");
  CHECK_FALSE(mesh[0].office);
  CHECK(mesh[0].world.cap_ceiling);
  CHECK(mesh[0].world.ceiling_clip_z_m == 2.5);
  CHECK_FALSE(parseBenchmarkWorlds("w.ply", 0.0)[0].world.cap_ceiling);

  const std::vector<BenchmarkWorld> one = parseBenchmarkWorlds("office:3:20x16", 2.5);
  REQUIRE(one.size() == 1);
  CHECK(one[0].name == "office3_20x16");
  REQUIRE(one[0].office);
  CHECK(one[0].office->seed == 3);
  CHECK(one[0].office->size_x_m == 20.0);
  CHECK(one[0].office->size_y_m == 16.0);
  CHECK(parseBenchmarkWorlds("office:4", 0.0)[0].office->size_x_m == sim::OfficeWorldConfig{}.size_x_m);

  const std::vector<BenchmarkWorld> range = parseBenchmarkWorlds("office:101-103:20x16", 2.5);
  REQUIRE(range.size() == 3);
  for (std::size_t i = 0; i < range.size(); ++i) {
    CHECK(range[i].office->seed == 101 + i);
    CHECK(range[i].name == "office" + std::to_string(101 + i) + "_20x16");
  }
  CHECK_NOTHROW(sim::validateBenchmarkWorlds(range, "X"));
  std::vector<BenchmarkWorld> twice = range;
  twice.push_back(range[1]);
  CHECK_THROWS_WITH(sim::validateBenchmarkWorlds(twice, "X"), Catch::Contains("office102_20x16 is listed twice"));
  CHECK_THROWS_WITH(sim::validateBenchmarkWorlds({}, "X"), Catch::Contains("X.worlds"));

  for (const char* bad : {"office:0", "office:", "office:x", "office:3-1", "office:1-101", "office:2:20by16",
                          "office:2:9x9", "office:-3", "office:1-"})
    CHECK_THROWS_WITH(parseBenchmarkWorlds(bad, 2.5), Catch::Contains(std::string("'") + bad + "'"));
}

TEST_CASE("a generated benchmark world is the generator's office under its own ceiling", "[sim][bench]") {
  const BenchmarkWorld w = parseBenchmarkWorlds("office:5:20x16", 0.0)[0];
  const sim::World world = sim::loadBenchmarkWorld(w);
  const sim::OfficeWorld office = sim::generateOffice(*w.office);
  // Cut and capped at the office's ceiling height, over the office's floor plan.
  CHECK(world.bounds().max().z() == Approx(w.office->height_m).margin(1e-6));
  CHECK(world.bounds().min().x() == Approx(0.0).margin(0.5));
  CHECK(world.bounds().max().x() == Approx(20.0).margin(0.5));
  CHECK(world.bounds().max().y() == Approx(16.0).margin(0.5));
  CHECK(world.stats().triangles_in == office.mesh.triangles.size());
}

namespace {
sim::AlcBenchmarkRun fakeRun(const std::string& world, const std::string& arm, std::uint64_t seed, double time_s,
                             double rmse_m, std::size_t loops, double coverage, double aligned_rmse_m = -1.0) {
  sim::AlcBenchmarkRun r{world, arm, seed, {}};
  r.summary.exploration_time_s = time_s;
  r.summary.accuracy_rmse_m = rmse_m;
  r.summary.accuracy_aligned_rmse_m = aligned_rmse_m;  // negative: not known (an older summary)
  r.summary.loop_closures = loops;
  r.summary.coverage = coverage;
  r.summary.coverage_seen = 0.995;  // what the camera saw: drift, not the exploration, lost the rest
  r.summary.finished = true;
  return r;
}
}  // namespace

TEST_CASE("bench alc tables pair the arms by world and seed", "[sim][bench][alc]") {
  sim::AlcBenchmarkConfig config;
  config.worlds = parseBenchmarkWorlds("office:1-2:20x16", 0.0);
  config.seeds = 2;
  sim::AlcBenchmarkResult result;
  // office1: ALC better on both seeds (after the alignment on seed 1 only); office2: worse on seed
  // 1, and seed 2 ends below 0.95; its runs do not know their aligned RMSE.
  result.runs = {fakeRun("office1_20x16", "no_alc", 1, 100, 0.20, 2, 0.99, 0.05),
                 fakeRun("office1_20x16", "alc", 1, 110, 0.10, 5, 0.99, 0.04),
                 fakeRun("office1_20x16", "no_alc", 2, 100, 0.20, 2, 0.99, 0.05),
                 fakeRun("office1_20x16", "alc", 2, 110, 0.10, 5, 0.98, 0.06),
                 fakeRun("office2_20x16", "no_alc", 1, 100, 0.10, 4, 0.97),
                 fakeRun("office2_20x16", "alc", 1, 130, 0.35, 3, 0.96),
                 fakeRun("office2_20x16", "no_alc", 2, 100, 0.20, 1, 0.90),
                 fakeRun("office2_20x16", "alc", 2, 90, 0.10, 4, 0.99),
                 fakeRun("office2_20x16", "no_alc", 3, 100, 0.20, 1, 0.90)};  // its ALC arm not done: unpaired
  const std::string md = sim::alcBenchmarkMarkdown(result, config);
  INFO(md);
  // Pooled over the 4 pairs: times 400 vs 440 (+10 %), ALC better in 3, one incomplete run per arm
  // among the pairs, loop gain (3 + 3 - 1 + 3) / 4 = +2.0.
  CHECK(md.find("4 pairs") != std::string::npos);
  CHECK(md.find("time overhead: +10.0 %") != std::string::npos);
  CHECK(md.find("better in 3 of 4 pairs (75 %)") != std::string::npos);
  CHECK(md.find("loop-closure gain: +2.0") != std::string::npos);
  CHECK(md.find("incomplete runs: 1 without ALC, 0 with ALC; lowest coverage 0.900 / 0.960") != std::string::npos);
  // RMSEs compare fairly between complete runs: 3 pairs have both arms >= 0.95, ALC better in 2.
  CHECK(md.find("over the 3 pairs where both runs are complete: RMSE change +0.0167 ± 0.2021 m, ALC's map better in "
                "2 of 3, time overhead +16.7 %") != std::string::npos);
  // After each map's alignment: only the 2 pairs that know it, and only known values per arm.
  CHECK(md.find("0.0500 against 0.0500 m (ratio of the means 1.00); ALC's map better in 1 of 2 pairs") !=
        std::string::npos);
  CHECK(md.find("| accuracy RMSE after the 4-DOF alignment (m) | 0.0500 ± 0.0000 | 0.0500 ± 0.0141 |") !=
        std::string::npos);
  // Per world rows.
  CHECK(md.find("| office1_20x16 | 2 | 0.2000 / 0.1000 | 2 / 2 | 0.0500 / 0.0500 | 1 / 2 | 2.0 / 5.0 | 100 / 110 | "
                "+10.0 % | 0 / 0 |") != std::string::npos);
  CHECK(md.find(
            "| office2_20x16 | 2 | 0.1500 / 0.2250 | 1 / 2 | - | 0 / 0 | 2.5 / 3.5 | 100 / 110 | +10.0 % | 1 / 0 |") !=
        std::string::npos);
  CHECK(md.find("| 0.2000 / 0.0500 |") != std::string::npos);  // a run's RMSE and aligned RMSE
  CHECK(md.find("| 0.1000 / - | - |") != std::string::npos);   // not known, nor its yaw offset
  // Every run is listed, the unpaired one too, with the coverage the camera saw beside the map's.
  CHECK(md.find("| office2_20x16 | 3 | no_alc |") != std::string::npos);
  CHECK(md.find("| 0.900 (0.995) |") != std::string::npos);
}
