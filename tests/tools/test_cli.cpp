// The vdbmap program end to end: integrate -> info -> mesh -> eval on the 4 Replica frames, and
// bad input that must fail loudly without replacing good outputs.
#include "common/shared_data.hpp"
#include "vdbmap/camera.hpp"
#include "vdbmap/io/png_io.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;

namespace {
const fs::path kReplica = vdbmap::test::sharedDataDir() / "nvblox_testdata" / "replica";

int run(const std::string& args, const fs::path& out_file) {
  const std::string cmd = std::string(VDBMAP_CLI_PATH) + " " + args + " > " + out_file.string() + " 2>&1";
  return std::system(cmd.c_str());
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

fs::path freshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}
}  // namespace

TEST_CASE("integrate, info, mesh and eval chain on a small real log with JSON summaries", "[cli]") {
  vdbmap::test::requireSharedData("nvblox_testdata/replica/office0");
  const fs::path dir = freshDir("vdbmap_cli_chain");
  const fs::path map = dir / "map.vdb", log = dir / "log.txt";
  REQUIRE(run("integrate " + (kReplica / "office0").string() + " -o " + map.string() + " --voxel-size 0.05 --mode all" +
                  " --json " + (dir / "integrate.json").string(),
              log) == 0);
  const auto integrate = nlohmann::json::parse(slurp(dir / "integrate.json"));
  CHECK(integrate.at("frames_integrated") == 4);
  CHECK(integrate.at("frames_skipped") == 0);
  CHECK(integrate.at("integrate_s").get<double>() > 0.0);
  CHECK(integrate.at("ms_per_frame_median").get<double>() > 0.0);
  CHECK(integrate.at("keyframes_kept") == 4);

  CHECK(integrate.at("load_ahead") == true);
  // Decoding each frame before its integration (as Open3D's script is timed) makes the same map.
  REQUIRE(run("integrate " + (kReplica / "office0").string() + " -o " + (dir / "serial.vdb").string() +
                  " --voxel-size 0.05 --mode all --load-ahead off --json " + (dir / "serial.json").string(),
              log) == 0);
  CHECK(nlohmann::json::parse(slurp(dir / "serial.json")).at("load_ahead") == false);
  CHECK(vdbmap::TsdfVolume::load(dir / "serial.vdb").exactlyEquals(vdbmap::TsdfVolume::load(map)));

  REQUIRE(run("info " + map.string() + " --json " + (dir / "info.json").string(), log) == 0);
  const auto info = nlohmann::json::parse(slurp(dir / "info.json"));
  REQUIRE(info.at("grids").size() == 2);
  CHECK(info.at("grids")[0].at("name") == "tsdf");
  CHECK(info.at("grids")[0].at("active_voxels").get<long>() > 10000);
  CHECK(info.at("metadata").at("voxel_size_m") == "0.05");
  CHECK(info.at("has_exact_state") == true);

  REQUIRE(run("mesh " + map.string() + " -o " + (dir / "mesh.ply").string(), log) == 0);
  CHECK(fs::file_size(dir / "mesh.ply") > 10000);

  REQUIRE(run("eval " + map.string() + " --gt " + (kReplica / "office0_mesh.ply").string() + " --json " +
                  (dir / "eval.json").string(),
              log) == 0);
  const auto eval = nlohmann::json::parse(slurp(dir / "eval.json"));
  // Four noise-free rendered frames at 5 cm voxels: the surface is within a fraction of a voxel.
  CHECK(eval.at("accuracy_rmse_m").get<double>() < 0.5 * 0.05);
  CHECK(eval.at("accuracy_median_m").get<double>() < 0.2 * 0.05);
  CHECK(eval.at("completeness").get<double>() > 0.1);
  CHECK(eval.at("completeness_threshold_m").get<double>() == Approx(0.1));
}

TEST_CASE("a failed run names the problem and leaves an existing map untouched", "[cli][bad-input]") {
  const fs::path dir = freshDir("vdbmap_cli_bad");
  const fs::path log = dir / "log.txt";
  const fs::path map = dir / "map.vdb";
  { std::ofstream(map) << "a good map from an earlier run"; }

  // A log whose frames.csv lists a missing depth file.
  const fs::path bad = dir / "badlog";
  fs::create_directories(bad);
  std::ofstream(bad / "sensor.json") << R"({"kind": "depth", "width": 4, "height": 3, "fx": 2.0, "fy": 2.0,
                                           "cx": 1.5, "cy": 1.0, "depth_scale": 0.001})";
  std::ofstream(bad / "frames.csv") << "timestamp,file,tx,ty,tz,qx,qy,qz,qw\n0.0,missing.png,0,0,0,0,0,0,1\n";
  CHECK(run("integrate " + bad.string() + " -o " + map.string(), log) != 0);
  const std::string out = slurp(log);
  CHECK(out.find("missing.png") != std::string::npos);
  CHECK(slurp(map) == "a good map from an earlier run");

  CHECK(run("integrate /nonexistent/log -o " + map.string(), log) != 0);
  CHECK(slurp(log).find("/nonexistent/log") != std::string::npos);
  CHECK(run("info " + (dir / "log.txt").string(), log) != 0);
  CHECK(run("integrate " + bad.string() + " -o " + map.string() + " --mode sometimes", log) != 0);
  CHECK(slurp(log).find("sometimes") != std::string::npos);
}

TEST_CASE("integrate checks its outputs before working and never writes an empty map over a good one", "[cli][bad-input]") {
  const fs::path dir = freshDir("vdbmap_cli_outputs");
  const fs::path log = dir / "log", out = dir / "out.txt";
  fs::create_directories(log);
  std::ofstream(log / "sensor.json") << R"({"kind": "depth", "width": 16, "height": 12, "fx": 10.0, "fy": 10.0,
    "cx": 7.5, "cy": 5.5, "depth_scale": 0.001, "min_range_m": 0.1, "max_range_m": 5.0})";
  vdbmap::io::writeDepthPng(log / "d0.png", vdbmap::DepthImage(16, 12, 2.0f), 0.001);
  std::ofstream(log / "frames.csv") << "timestamp,file,tx,ty,tz,qx,qy,qz,qw\n0.0,d0.png,0,0,0,0,0,0,1\n";

  SECTION("-o without .vdb writes MAP.vdb and its companion beside it") {
    REQUIRE(run("integrate " + log.string() + " -o " + (dir / "map").string(), out) == 0);
    CHECK(fs::exists(dir / "map.vdb"));
    CHECK(fs::exists(dir / "map.exact.vdb"));
    CHECK_FALSE(fs::exists(dir / "map"));
  }
  SECTION("a --json or --mesh in a missing folder fails before any map is written") {
    CHECK(run("integrate " + log.string() + " -o " + (dir / "m.vdb").string() + " --json " +
                  (dir / "nowhere" / "s.json").string(),
              out) != 0);
    CHECK(slurp(out).find("nowhere") != std::string::npos);
    CHECK_FALSE(fs::exists(dir / "m.vdb"));
    CHECK(run("integrate " + log.string() + " -o " + (dir / "m.vdb").string() + " --mesh " + dir.string(), out) != 0);
    CHECK(slurp(out).find("is a folder") != std::string::npos);
    CHECK_FALSE(fs::exists(dir / "m.vdb"));
  }
  SECTION("a log whose frames all fail leaves the good map as it was") {
    REQUIRE(run("integrate " + log.string() + " -o " + (dir / "good.vdb").string(), out) == 0);
    const std::string before = slurp(dir / "good.vdb");
    std::ofstream(log / "frames.csv") << "timestamp,file,tx,ty,tz,qx,qy,qz,qw\n0.0,missing.png,0,0,0,0,0,0,1\n";
    CHECK(run("integrate " + log.string() + " -o " + (dir / "good.vdb").string() + " --on-bad-frame skip", out) != 0);
    CHECK(slurp(out).find("no frame was integrated") != std::string::npos);
    CHECK(slurp(dir / "good.vdb") == before);
  }
  fs::remove_all(dir);
}

TEST_CASE("drift-log refuses to replace a log without --overwrite", "[cli][bad-input]") {
  const fs::path dir = freshDir("vdbmap_cli_drift_log_overwrite");
  const fs::path existing = dir / "existing", out = dir / "out.txt";
  fs::create_directories(existing);
  const std::string listing = "timestamp,file,tx,ty,tz,qx,qy,qz,qw\n";
  std::ofstream(existing / "frames.csv") << listing;
  CHECK(run("drift-log " + dir.string() + " -o " + existing.string(), out) != 0);
  CHECK(slurp(out).find("--overwrite") != std::string::npos);
  CHECK(slurp(existing / "frames.csv") == listing);
  fs::remove_all(dir);
}
