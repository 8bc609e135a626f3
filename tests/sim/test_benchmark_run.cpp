// The benchmarks' concurrent runner: every task runs once and its finishing step sees its result,
// one finishing step at a time, in the order the tasks end; a failure stops new tasks and is
// rethrown.
#include "internal/benchmark_run.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <thread>
#include <vector>

using vdbmap::sim::internal::runConcurrently;

TEST_CASE("runConcurrently runs each task once and serialises the finishing steps", "[sim][bench]") {
  for (std::size_t jobs : {1, 2, 4}) {
    CAPTURE(jobs);
    constexpr std::size_t n = 64;
    std::vector<int> seen(n, 0);
    std::vector<std::size_t> order;  // not thread-safe: only the finishing step touches it
    long long sum = 0;
    runConcurrently(
        n, jobs, [](std::size_t i) { return i * i; },
        [&](std::size_t i, std::size_t square) {
          ++seen[i];
          order.push_back(i);
          sum += (long long)square;
        });
    CHECK(order.size() == n);
    CHECK(std::count(seen.begin(), seen.end(), 1) == long(n));
    CHECK(sum == 63LL * 64 * 127 / 6);  // sum of i^2 for i < 64
  }
}

TEST_CASE("runConcurrently finishes tasks in the order they end", "[sim][bench]") {
  // Task 0 waits until task 1 has finished, so with two threads task 1 must end first (a runner
  // that finished in index order would leave task 0 waiting: it gives up after 30 s instead).
  std::atomic<bool> one_finished{false};
  std::vector<std::size_t> order;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  runConcurrently(
      2, 2,
      [&](std::size_t i) {
        while (i == 0 && !one_finished.load() && std::chrono::steady_clock::now() < give_up) std::this_thread::yield();
        return i;
      },
      [&](std::size_t i, std::size_t) {
        order.push_back(i);
        if (i == 1) one_finished = true;
      });
  CHECK(order == std::vector<std::size_t>{1, 0});
}

TEST_CASE("runConcurrently rethrows a task's failure once the running tasks are done", "[sim][bench]") {
  for (std::size_t jobs : {1, 3}) {
    CAPTURE(jobs);
    std::vector<std::size_t> finished;
    CHECK_THROWS_WITH(runConcurrently(
                          20, jobs,
                          [](std::size_t i) {
                            if (i == 5) throw std::runtime_error("task 5 failed");
                            return i;
                          },
                          [&](std::size_t i, std::size_t) { finished.push_back(i); }),
                      "task 5 failed");
    CHECK(std::find(finished.begin(), finished.end(), std::size_t(5)) == finished.end());
    // One thread stops right at the failure: tasks 0-4 finished, none after.
    if (jobs == 1) CHECK(finished == std::vector<std::size_t>{0, 1, 2, 3, 4});
  }
}

TEST_CASE("runBenchmarkRuns starts seed by seed, skips runs done before and lists all in table order", "[sim][bench]") {
  // Two worlds x three seeds in table order; world 0's seed 2 and world 1's seed 1 were done before.
  const std::vector<std::uint64_t> seed_of = {1, 2, 3, 1, 2, 3};
  std::vector<std::optional<int>> before(6);
  before[1] = 101;
  before[3] = 103;
  std::vector<std::size_t> started;
  std::vector<std::vector<int>> listed;
  vdbmap::sim::internal::runBenchmarkRuns<int>(
      seed_of, before, 1,
      [&](std::size_t i) {
        started.push_back(i);
        return int(i);
      },
      [&](const int&, const std::vector<int>& done) { listed.push_back(done); });
  CHECK(started == std::vector<std::size_t>{0, 4, 2, 5});  // seed 1, then 2, then 3; never 1 or 3
  REQUIRE(listed.size() == 4);
  CHECK(listed.front() == std::vector<int>{0, 101, 103});
  CHECK(listed.back() == std::vector<int>{0, 101, 2, 103, 4, 5});
}

TEST_CASE("A benchmark's header says when the safety layer's near-surface rule is on", "[sim][bench]") {
  vdbmap::planner::SafetyConfig safety;
  safety.enabled = true;
  using vdbmap::sim::internal::safetyDescription;
  CHECK(safetyDescription(safety, "s3").find("near surfaces") == std::string::npos);
  safety.near_drift_tolerance_m = 0.1;
  CHECK(safetyDescription(safety, "s3").find("(near surfaces only frames drifted at most 0.10 m: 2.6 s)") !=
        std::string::npos);
  CHECK(safetyDescription(safety, "s1").find("near surfaces") == std::string::npos);  // no drift: nothing to go by
  CHECK(safetyDescription(safety, "s3").find("path flown") == std::string::npos);
  safety.path_drift = vdbmap::planner::PathDriftScope::NearSurfaces;
  CHECK(safetyDescription(safety, "s3").find("(the path flown counts in a frame's drift: near)") != std::string::npos);
}

namespace {
/// A benchmark run's folder for the resume checks: recordings of summary.json and the identity a
/// call asks for.
struct ResumeFolder {
  explicit ResumeFolder(const std::string& name) : dir(std::filesystem::temp_directory_path() / name) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    world.name = "room";
    world.mesh = dir / "room.ply";
  }
  ~ResumeFolder() { std::filesystem::remove_all(dir); }
  void record(const nlohmann::json& summary) const { std::ofstream(dir / "summary.json") << summary.dump(); }
  nlohmann::json identity(const vdbmap::planner::SafetyConfig& safety, bool look_into_unknown,
                          const std::string& drift_level = "s3") const {
    return vdbmap::sim::internal::runIdentity("run", world, 0.1, 60.0, false, 0.2, safety, drift_level,
                                              look_into_unknown, vdbmap::sim::LoopClosureMode::PoseGraph);
  }
  std::optional<vdbmap::sim::ExplorationSummary> resume(const nlohmann::json& identity) const {
    return vdbmap::sim::internal::startingPoint(true, dir, identity);
  }

  std::filesystem::path dir;
  vdbmap::sim::BenchmarkWorld world;
};
}  // namespace

TEST_CASE("A benchmark records the map's thin structure as read without drift (s1) and not under it", "[sim][bench]") {
  const ResumeFolder folder("vdbmap_bench_identity_map_thin");
  vdbmap::planner::SafetyConfig safety;
  safety.enabled = true;  // the default: the map's thin structure only where the odometry does not drift
  CHECK(folder.identity(safety, false, "s1").at("safety_map_thin") == true);
  CHECK(folder.identity(safety, false, "s3").at("safety_map_thin") == false);
  using vdbmap::sim::internal::safetyDescription;
  CHECK(safetyDescription(safety, "s1").find("no thin structure from the map") == std::string::npos);
  CHECK(safetyDescription(safety, "s3").find("(no thin structure from the map)") != std::string::npos);
  // An s1 run flown before the rule (thin structure left to the recent frames) does not stand for
  // one flown with it.
  safety.map_thin_without_drift = false;
  folder.record(folder.identity(safety, false, "s1"));
  safety.map_thin_without_drift = true;
  CHECK_THROWS_WITH(folder.resume(folder.identity(safety, false, "s1")),
                    Catch::Contains("was run with safety_map_thin"));
  // Off the layer flight reads the map's thin structure anyway.
  safety.enabled = false;
  CHECK(folder.identity(safety, false, "s3").at("safety_map_thin") == true);
}

TEST_CASE("Resuming refuses a run flown with another path-drift scope, and reads older runs as flown without it",
          "[sim][bench]") {
  using vdbmap::planner::PathDriftScope;
  const ResumeFolder folder("vdbmap_bench_identity_path_drift");
  vdbmap::planner::SafetyConfig safety;
  safety.enabled = true;
  const auto identityWith = [&](PathDriftScope scope) {
    safety.path_drift = scope;
    return folder.identity(safety, false);
  };
  // Recorded with `near`, asked without it: the error names the option.
  folder.record(identityWith(PathDriftScope::NearSurfaces));
  const nlohmann::json off = identityWith(PathDriftScope::Off);
  CHECK(off.at("safety_path_drift") == "off");
  CHECK_THROWS_WITH(folder.resume(off), Catch::Contains("was run with safety_path_drift"));
  // A summary from before the option has no key: it ran without it, so the identity check passes
  // and what fails is reading the (incomplete) summary itself.
  nlohmann::json older = off;
  older.erase("safety_path_drift");
  folder.record(older);
  CHECK_THROWS_WITH(folder.resume(off), !Catch::Contains("was run with"));
  CHECK_THROWS_WITH(folder.resume(identityWith(PathDriftScope::NearSurfaces)),
                    Catch::Contains("safety_path_drift = (not recorded)"));
}

TEST_CASE("Resuming refuses a run whose viewpoints scored by another rule, and reads older runs as FUEL's rule",
          "[sim][bench]") {
  const ResumeFolder folder("vdbmap_bench_identity_view_score");
  const nlohmann::json voxel = folder.identity({}, false), into_unknown = folder.identity({}, true);
  CHECK(voxel.at("view_score") == "voxel");
  CHECK(into_unknown.at("view_score") == "into-unknown");
  folder.record(into_unknown);
  CHECK_THROWS_WITH(folder.resume(voxel), Catch::Contains("was run with view_score"));
  // Before the key existed every run scored by FUEL's rule: such a summary passes the identity
  // check for `voxel` (what fails is reading the incomplete summary) and fails it for into-unknown.
  nlohmann::json older = voxel;
  older.erase("view_score");
  folder.record(older);
  CHECK_THROWS_WITH(folder.resume(voxel), !Catch::Contains("was run with"));
  CHECK_THROWS_WITH(folder.resume(into_unknown), Catch::Contains("view_score = (not recorded)"));
}
