// The Table II benchmark (sim/drift_benchmark.hpp) end to end on a small world.
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "sim/sim_test_helpers.hpp"
#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/sim/drift_benchmark.hpp"
#include "vdbmap/sim/exploration.hpp"
#include "vdbmap/test_io_helpers.hpp"

#include <fstream>

using namespace vdbmap;
using namespace vdbmap::sim;

namespace {

/// The benchmark on a room with a box, written into `dir`: once round the room and back to the
/// start facing as at first (the loop closes there), with 80x60 frames to keep it quick.
DriftBenchmarkConfig smallRoomBenchmark(const test::TempDir& dir) {
  io::writePlyMesh(dir / "room.ply", test::roomWithBox());
  test::writeText(dir / "path.txt",
                  "-2 -1.2 1.2 0\n2 -1.2 1.2 1.57\n2 1.2 1.2 3.14\n-2 1.2 1.2 4.71\n-2 -1.2 1.2 6.28\n");
  DriftBenchmarkConfig c;
  c.world_mesh = dir / "room.ply";
  c.trajectory_file = dir / "path.txt";
  c.simulator.camera.intrinsics = {80, 60, 48.4, 48.4, 40.0, 30.0};
  c.simulator.loop.min_age_s = 8.0;
  return c;
}

}  // namespace

TEST_CASE("bench drift: one flight per level, every mode replayed and evaluated, table.json and table.md",
          "[sim][bench]") {
  test::TempDir dir;
  DriftBenchmarkConfig c = smallRoomBenchmark(dir);
  c.levels = {"s1", "s4"};
  c.modes = {ConsistencyMode::None, ConsistencyMode::Keyframes};
  std::vector<std::string> lines;
  c.report = [&](const std::string& line) { lines.push_back(line); };
  const DriftBenchmarkResult r = runDriftBenchmark(c, dir / "out");

  REQUIRE(r.rows.size() == 4);
  REQUIRE(r.levels.size() == 2);
  CHECK(r.levels[1].flight.loop_closures.size() >= 1);
  CHECK(lines.size() == 1 + 2 + 4);
  std::ifstream json_file(dir / "out" / "table.json");
  const auto table = nlohmann::json::parse(json_file);
  REQUIRE(table.size() == 4);
  for (const auto& row : table) {
    for (const char* key :
         {"level", "mode", "accuracy_rmse_m", "completeness", "frames_total", "keyframes_kept", "wall_s"})
      CHECK(row.contains(key));
    CHECK(row.at("frames_total") == r.levels[0].flight.frames);
    CHECK(row.at("accuracy_rmse_m").get<double>() > 0.0);
  }
  // Rows are in level, then mode order; without drift the modes agree closely, and keyframes keep
  // fewer frames than were integrated.
  CHECK(table[0].at("level") == "s1");
  CHECK(table[0].at("mode") == "none");
  CHECK(table[1].at("mode") == "keyframes");
  CHECK(table[1].at("keyframes_kept").get<int>() < table[1].at("frames_total").get<int>());
  CHECK(table[0].at("accuracy_rmse_m").get<double>() < 0.05);
  // With drift and ground-truth corrections (the default), keyframes beat no correction.
  CHECK(table[3].at("accuracy_rmse_m").get<double>() < table[2].at("accuracy_rmse_m").get<double>());
  CHECK(std::filesystem::exists(dir / "out" / "s4" / "keyframes.ply"));
  std::ifstream md_file(dir / "out" / "table.md");
  const std::string md((std::istreambuf_iterator<char>(md_file)), std::istreambuf_iterator<char>());
  CHECK(md.find("| Voxblox | none |") != std::string::npos);
  CHECK(md.find("| s1 | s4 |") != std::string::npos);

  c.levels = {"s7"};
  CHECK_THROWS_WITH(runDriftBenchmark(c, dir / "bad"), Catch::Contains("s7"));
}

TEST_CASE("bench drift with counted re-integration budgets gives the same keyframes row on every run",
          "[sim][bench]") {
  test::TempDir dir;
  DriftBenchmarkConfig c = smallRoomBenchmark(dir);
  c.levels = {"s4"};
  c.modes = {ConsistencyMode::Keyframes};
  c.write_meshes = false;
  setReintegrationBudget(c.mapper.reintegration, BudgetMode::Counted);
  CHECK(c.mapper.reintegration.budget_frames == kCountedReintegrationFrames);
  const DriftBenchmarkResult a = runDriftBenchmark(c, dir / "a");
  const DriftBenchmarkResult b = runDriftBenchmark(c, dir / "b");
  REQUIRE(a.rows.size() == 1);
  REQUIRE(b.rows.size() == 1);
  CHECK(a.rows[0].reintegrated_frames > 0);  // the correction was worked off in counted cycles
  CHECK(a.rows[0].reintegrated_frames == b.rows[0].reintegrated_frames);
  CHECK(a.rows[0].keyframes_kept == b.rows[0].keyframes_kept);
  CHECK(a.rows[0].accuracy_rmse_m == b.rows[0].accuracy_rmse_m);
  CHECK(a.rows[0].completeness == b.rows[0].completeness);

  setReintegrationBudget(c.mapper.reintegration, BudgetMode::WallClock);
  CHECK(c.mapper.reintegration.budget_ms == ReintegrationConfig{}.budget_ms);
  CHECK(c.mapper.reintegration.budget_frames == ReintegrationConfig{}.budget_frames);
}
