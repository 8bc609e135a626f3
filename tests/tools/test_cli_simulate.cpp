// `vdbmap simulate` writes a log that `vdbmap integrate` replays; bad arguments fail loudly.
#include "tools/cli_test_util.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "vdbmap/io/mesh_io.hpp"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;

namespace {
int run(const std::string& args, const fs::path& out_file) { return vdbmap::test::runCli(args, out_file); }
using vdbmap::test::slurp;
using vdbmap::test::freshDir;
/// A closed 6 x 4 x 2.5 m room (inward or outward facing does not matter to the simulator).
vdbmap::TriangleMesh room() {
  vdbmap::TriangleMesh m;
  for (int k = 0; k < 8; ++k) m.vertices.emplace_back(k & 1 ? 3.0f : -3.0f, k & 2 ? 2.0f : -2.0f, k & 4 ? 2.5f : 0.0f);
  const int quads[6][4] = {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.emplace_back(q[0], q[1], q[2]);
    m.triangles.emplace_back(q[0], q[2], q[3]);
  }
  return m;
}
}  // namespace

TEST_CASE("vdbmap simulate records a drifting flight that vdbmap integrate replays", "[cli][sim]") {
  const fs::path dir = freshDir("vdbmap_cli_simulate");
  vdbmap::io::writePlyMesh(dir / "room.ply", room());
  {
    std::ofstream w(dir / "path.txt");
    w << "# a short flight across the room\n-2 -1 1.2 0\n2 -1 1.2 0.8\n2 1 1.3\n";
  }
  const fs::path log = dir / "log", out = dir / "out.txt";
  REQUIRE(run("simulate --world " + (dir / "room.ply").string() + " --drift s3 --seed 2 --trajectory " +
                  (dir / "path.txt").string() + " -o " + log.string(),
              out) == 0);
  CHECK(slurp(out).find("frames over") != std::string::npos);
  CHECK(fs::exists(log / "sensor.json"));
  CHECK(fs::exists(log / "groundtruth.txt"));
  const auto sim = nlohmann::json::parse(slurp(log / "simulation.json"));
  CHECK(sim.at("drift").at("sigma2_xyz_m2ps2") == 5e-2);
  CHECK(sim.at("drift").at("frame") == "body");
  const std::size_t frames = sim.at("frames");
  CHECK(frames > 40);

  REQUIRE(run("integrate " + log.string() + " -o " + (dir / "map.vdb").string() + " --mode keyframes --json " +
                  (dir / "integrate.json").string(),
              out) == 0);
  const auto summary = nlohmann::json::parse(slurp(dir / "integrate.json"));
  CHECK(summary.at("frames_integrated") == frames);
  CHECK(summary.at("format") == "log");
  CHECK(summary.at("active_voxels").get<long>() > 1000);

  // The same folder again without --overwrite is refused; with it, replaced.
  CHECK(run("simulate --world " + (dir / "room.ply").string() + " --trajectory " + (dir / "path.txt").string() +
                " -o " + log.string(),
            out) != 0);
  CHECK(slurp(out).find("already holds a log") != std::string::npos);
  CHECK(run("simulate --world " + (dir / "room.ply").string() + " --drift s9 -o " + (dir / "x").string(), out) != 0);
  CHECK(run("simulate --world " + (dir / "missing.ply").string() + " -o " + (dir / "x").string(), out) != 0);
  fs::remove_all(dir);
}
