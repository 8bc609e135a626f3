// `vdbmap explore` writes a complete run folder whose log `vdbmap integrate` replays; the same
// command gives the same run; bad arguments fail loudly.
#include "tools/cli_test_util.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "tools/cli_test_worlds.hpp"

#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/io/tum_trajectory.hpp"
#include "vdbmap/sim/trajectory_alignment.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace fs = std::filesystem;

namespace {
int run(const std::string& args, const fs::path& out_file) { return vdbmap::test::runCli(args, out_file); }
using vdbmap::test::slurp;
std::size_t lineCount(const fs::path& p) {
  std::ifstream in(p);
  std::size_t n = 0;
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '#') ++n;
  return n;
}
}  // namespace

TEST_CASE("vdbmap explore writes a run folder whose log vdbmap integrate replays, and repeats it exactly", "[cli][explore]") {
  const fs::path dir = fs::temp_directory_path() / "vdbmap_cli_explore";
  fs::remove_all(dir);
  fs::create_directories(dir);
  vdbmap::io::writePlyMesh(dir / "room.ply", vdbmap::test::roomWithBox());
  const fs::path runs = dir / "run", out = dir / "out.txt";
  REQUIRE(run("explore --world " + (dir / "room.ply").string() + " --ceiling 0 --drift s2 --seed 3 --max-time-s 90 -o " +
                  runs.string(),
              out) == 0);
  INFO(slurp(out));
  CHECK(slurp(out).find("coverage") != std::string::npos);
  for (const char* f : {"map.vdb", "mesh.ply", "trajectory_true.txt", "trajectory_odom.txt", "summary.json",
                        "log/sensor.json", "log/frames.csv", "log/groundtruth.txt", "log/simulation.json"})
    CHECK(fs::exists(runs / f));
  const auto s = nlohmann::json::parse(slurp(runs / "summary.json"));
  for (const char* key : {"exploration_time_s", "path_length_m", "coverage", "loop_closures", "collisions",
                          "planner_ms_median", "planner_ms_max", "frames_total", "keyframes_kept", "accuracy_rmse_m",
                          "completeness", "finished", "alc_enabled", "epsilon", "alc_detours", "alc_time_s"})
    CHECK(s.contains(key));
  {
    // Each failed visit is an event that says which: its target, its viewpoint, how it was judged.
    std::size_t failed = 0;
    for (const auto& e : s.at("events")) {
      if (e.at("what") != "visit_failed") continue;
      ++failed;
      CHECK(e.at("cluster").get<std::uint64_t>() != 0);
      CHECK(e.at("view_W").size() == 3);
      CHECK(e.at("judged_voxels").get<std::size_t>() > 0);
      CHECK(e.at("gone_fraction").get<double>() <= 0.5);
    }
    CHECK(failed == s.at("visit_failures").get<std::size_t>());  // 2 in this run
  }
  // s2 drifts: the map holds its keyframes off where the camera was, by what the online estimate
  // was off at those frames at most, when no loop closed to correct them.
  CHECK(s.at("keyframe_error_rmse_m").get<double>() > 0.0);
  if (s.at("loop_closures") == 0)
    CHECK(s.at("keyframe_error_rmse_m").get<double>() <= s.at("estimate_error_max_m").get<double>());
  CHECK(s.at("alc_enabled") == false);  // ALC is off unless asked for
  CHECK(s.at("alc_detours") == 0);
  CHECK(s.at("finished") == true);
  CHECK(s.at("collisions") == 0);
  // The room is small and mostly floor and ceiling, which a level camera sees only at its frustum's
  // edges; keyframe pruning (coarse cells of 2 voxels) releases some of those voxels. The coverage
  // goal itself (>= 0.95) is asserted on two rooms in tests/sim/test_exploration.cpp.
  CHECK(s.at("coverage").get<double>() >= 0.85);
  // What the camera saw at the true poses: in this small room nearly all of it, drift or not.
  CHECK(s.at("coverage_seen").get<double>() >= 0.85);
  CHECK(s.at("coverage_seen").get<double>() <= 1.0);
  // Complete exactly when finished at 0.95 coverage or more; an incomplete finish is said.
  CHECK(s.at("complete") == (s.at("coverage").get<double>() >= 0.95));
  CHECK((slurp(out).find("incomplete:") != std::string::npos) == (s.at("complete") == false));
  const std::size_t frames = s.at("frames_total");
  CHECK(frames > 30);
  CHECK(lineCount(runs / "trajectory_true.txt") == frames);
  CHECK(lineCount(runs / "trajectory_odom.txt") == frames);
  {
    // The poses the final map holds its keyframes at, one per keyframe kept; their error against
    // the true pose of the same frame is the summary's keyframe_error_rmse_m.
    const auto keyframes = vdbmap::io::readTumTrajectory(runs / "trajectory_keyframes.txt");
    const auto truth = vdbmap::io::readTumTrajectory(runs / "trajectory_true.txt");
    CHECK(keyframes.size() == s.at("keyframes_kept").get<std::size_t>());
    double sum = 0.0;
    for (const auto& k : keyframes) {
      const auto same = std::find_if(truth.begin(), truth.end(),
                                     [&](const auto& t) { return std::abs(t.timestamp_s - k.timestamp_s) < 1e-4; });
      REQUIRE(same != truth.end());
      sum += (same->T_W_S.translation() - k.T_W_S.translation()).squaredNorm();
    }
    REQUIRE(!keyframes.empty());
    // (TUM files hold positions to 0.1 mm)
    CHECK(std::sqrt(sum / double(keyframes.size())) ==
          Approx(s.at("keyframe_error_rmse_m").get<double>()).margin(1e-3));

    // The map's 4-DOF alignment with the truth: the best yaw and translation for these keyframes,
    // never worse than none (no alignment is one of those it chooses from), and applied to the map
    // for accuracy_aligned_rmse_m.
    std::vector<vdbmap::Vec3d> map_W, true_W;
    for (const auto& k : keyframes) {
      map_W.push_back(k.T_W_S.translation());
      true_W.push_back(std::find_if(truth.begin(), truth.end(), [&](const auto& t) {
                         return std::abs(t.timestamp_s - k.timestamp_s) < 1e-4;
                       })->T_W_S.translation());
    }
    const vdbmap::sim::FlatPose A = vdbmap::sim::alignYawTranslation(map_W, true_W);
    const auto& alignment = s.at("map_alignment");
    CHECK(alignment.at("yaw_deg").get<double>() == Approx(A.yaw_rad * 180.0 / M_PI).margin(0.01));
    for (int a = 0; a < 3; ++a)
      CHECK(alignment.at("translation_m")[a].get<double>() == Approx(A.position_W[a]).margin(1e-3));
    CHECK(s.at("keyframe_error_aligned_rmse_m").get<double>() ==
          Approx(vdbmap::sim::alignedRmse(A, map_W, true_W)).margin(1e-3));
    CHECK(s.at("keyframe_error_aligned_rmse_m").get<double>() <= s.at("keyframe_error_rmse_m").get<double>() + 1e-9);
    CHECK(s.at("accuracy_aligned_rmse_m").get<double>() > 0.0);
  }

  // How the time went: coverage every second (and once more after the final correction, equal to
  // the summary's), a row per frame, activities summing to the flight's time.
  CHECK(lineCount(runs / "cycles.csv") == frames + 1);  // and the header
  {
    // Each row says why its frame replanned: the first plan after take-off among them.
    std::ifstream in(runs / "cycles.csv");
    std::string line;
    std::getline(in, line);
    CHECK(line == "t_s,mapper_ms,planner_ms,update_ms,frame_wall_ms,queued_frames,activity,replan");
    std::size_t starts = 0, none = 0;
    double update_max = 0.0;
    while (std::getline(in, line)) {
      const std::string reason = line.substr(line.rfind(',') + 1);
      starts += reason == "start";
      none += reason == "none";
      // The planner's whole work for the frame holds the replan's (both to 0.001 ms).
      std::istringstream fields(line);
      std::string t, mapper, planner, update;
      std::getline(fields, t, ',');
      std::getline(fields, mapper, ',');
      std::getline(fields, planner, ',');
      std::getline(fields, update, ',');
      REQUIRE(std::stod(update) >= std::stod(planner) - 0.0015);
      update_max = std::max(update_max, std::stod(update));
    }
    CHECK(starts >= 1);
    CHECK(none > frames / 2);
    CHECK(s.at("update_ms_max").get<double>() == Approx(update_max).margin(0.0015));
    CHECK(s.at("update_ms_p99").get<double>() <= s.at("update_ms_max").get<double>());
    CHECK(s.at("update_ms_median").get<double>() <= s.at("update_ms_p99").get<double>());
  }
  const double t_end = s.at("exploration_time_s");
  CHECK(lineCount(runs / "coverage.csv") >= std::size_t(t_end) + 1);
  {
    std::ifstream in(runs / "coverage.csv");
    std::string line, last;
    while (std::getline(in, line)) last = line;
    CHECK(std::stod(last.substr(last.find(',') + 1)) == Approx(s.at("coverage").get<double>()).margin(1e-6));
    const std::string seen = last.substr(last.find(',', last.find(',') + 1) + 1);  // the third column
    CHECK(std::stod(seen) == Approx(s.at("coverage_seen").get<double>()).margin(1e-6));
  }
  double activity_s = 0.0;
  for (const auto& [name, t] : s.at("activity_time_s").items()) activity_s += t.get<double>();
  CHECK(activity_s == Approx(t_end).margin(1e-6));
  CHECK(s.at("mean_speed_mps").get<double>() == Approx(s.at("path_length_m").get<double>() / t_end));
  const auto& ttc = s.at("time_to_coverage_s");
  REQUIRE(ttc.contains("0.50"));
  REQUIRE(!ttc.at("0.50").is_null());
  CHECK(ttc.at("0.50").get<double>() <= t_end);
  if (!ttc.at("0.80").is_null()) CHECK(ttc.at("0.50").get<double>() <= ttc.at("0.80").get<double>());

  // The run's report: one page, and a path that is no run is named.
  REQUIRE(run("report " + runs.string() + " -o " + (dir / "report.html").string(), out) == 0);
  CHECK(fs::file_size(dir / "report.html") > 500000);  // three.js alone is 0.7 MB
  CHECK(slurp(out).find("distance to the world") != std::string::npos);  // the recorded world colours the map
  CHECK(run("report " + (dir / "nowhere").string() + " -o " + (dir / "r.html").string(), out) != 0);
  CHECK(slurp(out).find("nowhere does not exist") != std::string::npos);
  CHECK(!fs::exists(dir / "r.html"));

  // Counted budgets (the default) make the same command give the same run.
  CHECK(s.at("budgets").at("path_max_iterations").get<std::uint64_t>() > 0);
  CHECK(s.at("budgets").at("reintegration_budget_frames").get<int>() > 0);
  const fs::path again = dir / "again";
  REQUIRE(run("explore --world " + (dir / "room.ply").string() + " --ceiling 0 --drift s2 --seed 3 --max-time-s 90 -o " +
                  again.string(),
              out) == 0);
  CHECK(slurp(again / "trajectory_true.txt") == slurp(runs / "trajectory_true.txt"));
  CHECK(slurp(again / "trajectory_odom.txt") == slurp(runs / "trajectory_odom.txt"));

  REQUIRE(run("integrate " + (runs / "log").string() + " -o " + (dir / "replay.vdb").string() + " --json " +
                  (dir / "integrate.json").string(),
              out) == 0);
  const auto replay = nlohmann::json::parse(slurp(dir / "integrate.json"));
  CHECK(replay.at("frames_integrated") == frames);
  CHECK(replay.at("format") == "log");

  // The same folder again without --overwrite is refused; bad options fail.
  CHECK(run("explore --world " + (dir / "room.ply").string() + " --max-time-s 5 -o " + runs.string(), out) != 0);
  CHECK(slurp(out).find("already holds") != std::string::npos);
  CHECK(run("explore --world " + (dir / "room.ply").string() + " --drift s7 -o " + (dir / "x").string(), out) != 0);
  // The near-surface rule's tolerance must lie below the window's drift tolerance (0.2 m).
  CHECK(run("explore --world " + (dir / "room.ply").string() + " --safety on --safety-near-tolerance 0.3 -o " +
                (dir / "x").string(),
            out) != 0);
  CHECK(slurp(out).find("near_drift_tolerance_m") != std::string::npos);
  CHECK(run("explore --world " + (dir / "room.ply").string() + " --min-cluster-size 0 -o " + (dir / "x").string(), out) != 0);
  CHECK(run("explore --world " + (dir / "room.ply").string() + " --revisit-rounds -1 -o " + (dir / "x").string(), out) != 0);
  CHECK(slurp(out).find("--revisit-rounds") != std::string::npos);
  CHECK(run("explore --world " + (dir / "room.ply").string() + " --w-dir -1 -o " + (dir / "x").string(), out) != 0);
  CHECK(slurp(out).find("--w-dir") != std::string::npos);
  CHECK(run("explore --world " + (dir / "room.ply").string() + " --alc maybe -o " + (dir / "x").string(), out) != 0);
  CHECK(run("explore --world " + (dir / "room.ply").string() + " --budgets sometimes -o " + (dir / "x").string(), out) != 0);
  CHECK(slurp(out).find("--budgets") != std::string::npos);
  CHECK(run("explore --world " + (dir / "room.ply").string() + " --view-score sideways -o " + (dir / "x").string(),
            out) != 0);
  CHECK(slurp(out).find("--view-score") != std::string::npos);
  CHECK(run("explore --world " + (dir / "room.ply").string() + " --epsilon -1 -o " + (dir / "x").string(), out) != 0);
  CHECK(run("explore --world " + (dir / "room.ply").string() + " --start 2.0,1.0 -o " + (dir / "x").string(), out) != 0);
  CHECK(run("explore --world " + (dir / "room.ply").string() + " --start 9,9,1 -o " + (dir / "x").string(), out) != 0);
  fs::remove_all(dir);
}

TEST_CASE("vdbmap explore without --world flies the embedded house, whatever the shared data", "[cli][explore][default-world]") {
  const fs::path dir = fs::temp_directory_path() / "vdbmap_cli_explore_default";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path runs = dir / "run", out = dir / "out.txt";
  // The shared data folder is not needed: the default world is embedded in data/worlds.
  REQUIRE(run("explore --drift s1 --max-time-s 1 -o " + runs.string(), out) == 0);
  INFO(slurp(out));
  const auto s = nlohmann::json::parse(slurp(runs / "summary.json"));
  CHECK(s.at("description").get<std::string>().find("data/worlds/small_house/small_house_visual_mesh.ply") !=
        std::string::npos);
  CHECK(s.at("frames_total").get<int>() >= 1);
  // The house's exploration box: 19 x 11.4 m.
  CHECK(s.at("box").at("max")[0].get<double>() == Approx(9.5));
  CHECK(s.at("box").at("min")[1].get<double>() == Approx(-5.7));
  // s1 has no drift: the map holds every keyframe exactly where the camera was.
  CHECK(s.at("keyframe_error_rmse_m").get<double>() == 0.0);
  // ... so aligning it with the truth moves nothing.
  CHECK(s.at("keyframe_error_aligned_rmse_m").get<double>() == Approx(0.0).margin(1e-9));
  CHECK(std::abs(s.at("map_alignment").at("yaw_deg").get<double>()) < 1e-6);
  CHECK(s.at("accuracy_aligned_rmse_m").get<double>() == Approx(s.at("accuracy_rmse_m").get<double>()).margin(1e-6));
  // The run starts with the turn on the spot, and its summary says so.
  CHECK(s.at("initial_turn") == true);
  CHECK(s.at("activity_time_s").at("initial_turn").get<double>() > 0.0);
  CHECK(s.at("description").get<std::string>().find("--no-initial-turn") == std::string::npos);

  // Without the turn the summary's command repeats the run: it names the flag.
  const fs::path no_turn = dir / "no_turn";
  REQUIRE(run("explore --drift s1 --max-time-s 1 --no-initial-turn -o " + no_turn.string(), out) == 0);
  const auto n = nlohmann::json::parse(slurp(no_turn / "summary.json"));
  CHECK(n.at("initial_turn") == false);
  CHECK(n.at("activity_time_s").at("initial_turn").get<double>() == 0.0);
  CHECK(n.at("description").get<std::string>().find(" --no-initial-turn") != std::string::npos);
  fs::remove_all(dir);
}
