// The report's data: mesh decimation stays on the surface, every input kind is read into what the
// page draws (checked against the files it came from), malformed inputs are named, and the page
// keeps its data inside its script element.
#include <catch2/catch.hpp>

#include "report/base64.hpp"
#include "report/mesh_decimation.hpp"
#include "report/report.hpp"

#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/io/tum_trajectory.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;
using nlohmann::json;
using vdbmap::TriangleMesh;
using vdbmap::Vec3d;
using vdbmap::Vec3f;

namespace {

/// An n x n grid of squares (2 triangles each) on z = 0 over [0, size]^2.
TriangleMesh planeGrid(int n, float size) {
  TriangleMesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.vertices.emplace_back(size * float(i) / float(n), size * float(j) / float(n), 0.0f);
  const auto at = [n](int i, int j) { return j * (n + 1) + i; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.triangles.emplace_back(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      m.triangles.emplace_back(at(i, j), at(i + 1, j + 1), at(i, j + 1));
    }
  return m;
}

/// A closed axis-aligned box's surface, each face an n x n grid.
TriangleMesh boxSurface(int n, float size) {
  TriangleMesh m;
  const TriangleMesh face = planeGrid(n, size);
  // Six faces from the z = 0 grid: (x, y) -> the face's two free axes, the fixed one at 0 or size.
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int base = int(m.vertices.size());
      for (const Vec3f& v : face.vertices) {
        Vec3f p;
        p[axis] = side ? size : 0.0f;
        p[(axis + 1) % 3] = v.x();
        p[(axis + 2) % 3] = v.y();
        m.vertices.push_back(p);
      }
      for (const Eigen::Vector3i& t : face.triangles)
        m.triangles.emplace_back(base + t[0], base + (side ? t[2] : t[1]), base + (side ? t[1] : t[2]));
    }
  return m;
}

double distanceToBox(const Vec3f& p, float size) {
  // Inside or on the surface: the distance to the nearest face; outside: to the box.
  double inside = 1e9, outside = 0.0;
  for (int k = 0; k < 3; ++k) {
    inside = std::min({inside, double(std::fabs(p[k])), double(std::fabs(size - p[k]))});
    const double o = std::max({0.0, -double(p[k]), double(p[k]) - size});
    outside += o * o;
  }
  return outside > 0.0 ? std::sqrt(outside) : inside;
}

void writeText(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

std::string decodeBytes(const std::string& b64) {
  static const std::string alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string bytes;
  std::uint32_t acc = 0;
  int bits = 0;
  for (char c : b64) {
    if (c == '=') break;
    acc = (acc << 6) | std::uint32_t(alphabet.find(c));
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      bytes += char((acc >> bits) & 0xff);
    }
  }
  return bytes;
}

std::vector<float> decodeFloats(const std::string& b64) {
  const std::string bytes = decodeBytes(b64);
  std::vector<float> out(bytes.size() / 4);
  std::memcpy(out.data(), bytes.data(), out.size() * 4);
  return out;
}

const json& byId(const json& list, const std::string& id) {
  for (const json& item : list)
    if (item.value("id", "") == id) return item;
  FAIL("no item with id " << id);
  static const json none;
  return none;
}

/// A small explore run folder: a straight flight along x at 1 m/s for 10 s (true), the estimate
/// drifting 0.01 m/s in y, coverage rising linearly, a collision at t = 4 s, a loop closure at
/// t = 6 s between frames 60 and 10, a box mesh as the map.
fs::path writeExploreRun(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / name;
  fs::remove_all(dir);
  fs::create_directories(dir / "log");
  std::vector<vdbmap::io::StampedPose> truth, odom;
  std::string coverage = "t_s,coverage,coverage_seen,path_length_m,clusters,loop_closures,estimate_error_m,activity\n";
  std::string cycles = "t_s,mapper_ms,planner_ms,update_ms,frame_wall_ms,queued_frames,activity\n";
  for (int i = 0; i <= 100; ++i) {
    const double t = 0.1 * i;
    vdbmap::Pose3d T = vdbmap::Pose3d::Identity();
    T.translation() = Vec3d(t, 0.0, 1.0);
    truth.push_back({t, T});
    T.translation().y() = 0.01 * t;
    odom.push_back({t, T});
    cycles += std::to_string(t) + ",5.0," + (i % 10 == 0 ? "40.0,41.0" : "0,1.0") + ",20.0," + std::to_string(i % 7) +
              "," + (i >= 70 && i < 80 ? "loop_detour" : "to_target") + "\n";
    if (i % 10 == 0)
      coverage += std::to_string(t) + "," + std::to_string(0.09 * t) + "," + std::to_string(0.095 * t) + "," +
                  std::to_string(t) + ",3,0,0.0,to_target\n";
  }
  vdbmap::io::writeTumTrajectory(dir / "trajectory_true.txt", truth);
  vdbmap::io::writeTumTrajectory(dir / "trajectory_odom.txt", odom);
  writeText(dir / "coverage.csv", coverage);
  writeText(dir / "cycles.csv", cycles);
  const json summary = {{"exploration_time_s", 10.0},
                        {"coverage", 0.9},
                        {"loop_closures", 1},
                        {"collisions", 1},
                        {"voxel_size_m", 0.1},
                        {"start", {0.0, 0.0, 1.0, 0.0}},
                        {"description", "vdbmap explore </script><b>"},
                        {"activity_time_s", {{"to_target", 9.0}, {"loop_detour", 1.0}}},
                        {"events",
                         {{{"t_s", 4.0}, {"what", "collision"}},
                          {{"t_s", 6.0}, {"what", "loop_closure"}},
                          {{"t_s", 7.0}, {"what", "visit_failed"}}}}};
  writeText(dir / "summary.json", summary.dump());
  writeText(dir / "log" / "simulation.json",
            json{{"loop_closures", {{{"new_frame", 60}, {"old_frame", 10}, {"t_s", 6.0}}}}}.dump());
  vdbmap::io::writePlyMesh(dir / "mesh.ply", boxSurface(10, 2.0f));
  return dir;
}

}  // namespace

TEST_CASE("base64 encodes RFC 4648's test vectors", "[report][base64]") {
  const auto b64 = [](const std::string& s) { return vdbmap::report::base64(s.data(), s.size()); };
  CHECK(b64("") == "");
  CHECK(b64("f") == "Zg==");
  CHECK(b64("fo") == "Zm8=");
  CHECK(b64("foo") == "Zm9v");
  CHECK(b64("foob") == "Zm9vYg==");
  CHECK(b64("fooba") == "Zm9vYmE=");
  CHECK(b64("foobar") == "Zm9vYmFy");
  CHECK(b64(std::string("\xff\x00\x80", 3)) == "/wCA");
}

TEST_CASE("vertex clustering keeps a plane on its plane and a box's surface within a cell diagonal", "[report][decimation]") {
  const TriangleMesh plane = planeGrid(40, 4.0f);
  const TriangleMesh coarse = vdbmap::report::clusterVertices(plane, 0.5);
  CHECK(coarse.triangles.size() < plane.triangles.size() / 10);
  CHECK(!coarse.triangles.empty());
  for (const Vec3f& v : coarse.vertices) CHECK(v.z() == 0.0f);
  for (const Eigen::Vector3i& t : coarse.triangles) {  // no collapsed triangle survives, indices are valid
    CHECK((t[0] != t[1] && t[1] != t[2] && t[0] != t[2]));
    for (int k = 0; k < 3; ++k) CHECK((t[k] >= 0 && std::size_t(t[k]) < coarse.vertices.size()));
  }
  const float size = 2.0f;
  const double cell = 0.3;
  const TriangleMesh box = vdbmap::report::clusterVertices(boxSurface(30, size), cell);
  for (const Vec3f& v : box.vertices) CHECK(distanceToBox(v, size) <= cell * std::sqrt(3.0));
  CHECK_THROWS_AS(vdbmap::report::clusterVertices(plane, 0.0), std::invalid_argument);
}

TEST_CASE("decimation to a budget leaves small meshes alone and brings large ones under the budget", "[report][decimation]") {
  const TriangleMesh plane = planeGrid(100, 4.0f);  // 20000 triangles
  CHECK(vdbmap::report::decimateToBudget(plane, 20000, 0.01).triangles.size() == 20000);
  const TriangleMesh small = vdbmap::report::decimateToBudget(plane, 5000, 0.01);
  CHECK(small.triangles.size() <= 5000);
  CHECK(small.triangles.size() > 500);  // the smallest doubling that fits, not a collapse
}

TEST_CASE("an explore run's report holds its trajectories, events, time series and map", "[report][explore]") {
  const fs::path dir = writeExploreRun("vdbmap_report_explore");
  vdbmap::report::ReportStats stats;
  const json data = vdbmap::report::collectReportData(dir, {}, &stats);
  CHECK(stats.input == vdbmap::report::ReportInput::ExploreRun);
  CHECK(data.at("kind") == "explore");
  // Time series from the CSVs, unchanged.
  const json& cov = byId(data.at("plots"), "coverage");
  CHECK(cov.at("series")[0].at("y").back().get<double>() == Approx(0.9));
  CHECK(cov.at("series")[0].at("x").size() == 11);
  REQUIRE(cov.at("series").size() == 2);  // and what the camera saw
  CHECK(cov.at("series")[1].at("name") == "seen by the camera");
  CHECK(cov.at("series")[1].at("y").back().get<double>() == Approx(0.95));
  {  // a run written before coverage_seen: the map's coverage alone
    const fs::path old_run = writeExploreRun("vdbmap_report_explore_old");
    writeText(old_run / "coverage.csv",
              "t_s,coverage,path_length_m,clusters,loop_closures,estimate_error_m,activity\n"
              "0.0,0.1,0,1,0,0,to_target\n1.0,0.2,1,1,0,0,to_target\n");
    const json old_cov = byId(vdbmap::report::collectReportData(old_run, {}).at("plots"), "coverage");
    REQUIRE(old_cov.at("series").size() == 1);
    CHECK(old_cov.at("series")[0].at("y").back().get<double>() == Approx(0.2));
  }
  CHECK(cov.at("marks").size() == 1);
  CHECK(cov.at("marks")[0].at("x").get<double>() == Approx(6.0));
  const json& planner = byId(data.at("plots"), "planner_ms");
  CHECK(planner.at("series")[0].at("y").size() == 11);  // every 10th frame replanned
  REQUIRE(planner.at("series").size() == 2);            // and the whole update, every frame
  CHECK(planner.at("series")[1].at("y").size() == 101);
  CHECK(planner.at("series")[1].at("y")[10].get<double>() == Approx(41.0));
  const json& err = byId(data.at("plots"), "estimate_error");
  CHECK(err.at("series")[0].at("y").back().get<double>() == Approx(0.1).margin(1e-6));  // 0.01 m/s for 10 s
  // The scene: trajectories as written, the collision where the true path was at t = 4 s, the
  // loop edge between frames 60 and 10, the detour frames as segments.
  const json& scene = data.at("scene");
  const std::vector<float> xyz = decodeFloats(scene.at("lines")[0].at("xyz"));
  REQUIRE(xyz.size() == 101 * 3);
  CHECK(xyz[3 * 50] == Approx(5.0));
  CHECK(xyz[3 * 50 + 2] == Approx(1.0));
  std::size_t layers_seen = 0;
  for (const json& layer : scene.at("points"))
    for (const auto& [name, t] : {std::pair<std::string, double>{"collisions", 4.0}, {"failed visits", 7.0}})
      if (layer.at("name") == name) {
        REQUIRE(layer.at("points").size() == 1);
        CHECK(layer.at("points")[0].at("xyz")[0].get<double>() == Approx(t));  // the true path runs along x at 1 m/s
        ++layers_seen;
      }
  CHECK(layers_seen == 2);
  const std::vector<float> edge = decodeFloats(scene.at("segments")[0].at("xyz"));
  REQUIRE(edge.size() == 6);
  CHECK(edge[0] == Approx(6.0));
  CHECK(edge[3] == Approx(1.0));
  CHECK(decodeFloats(scene.at("segments")[1].at("xyz")).size() == 10 * 6);  // frames 70..79 on the detour
  // The map: the whole box (under the budget), coloured by height without a world.
  CHECK(scene.at("mesh").at("triangles") == 6 * 200);
  CHECK(!stats.coloured_by_error);
  CHECK(data.at("activity_time_s").at("loop_detour") == 1.0);
}

TEST_CASE("a report coloured against the world puts the map's vertices on the world at the scale's start", "[report][explore]") {
  const fs::path dir = writeExploreRun("vdbmap_report_world");
  vdbmap::io::writePlyMesh(dir / "world.ply", boxSurface(2, 2.0f));
  vdbmap::report::ReportConfig config;
  config.world = dir / "world.ply";
  vdbmap::report::ReportStats stats;
  const json data = vdbmap::report::collectReportData(dir, config, &stats);
  CHECK(stats.coloured_by_error);
  const json& legend = data.at("scene").at("mesh").at("legend");
  CHECK(legend.at("label").get<std::string>().find("distance") != std::string::npos);
  // The map is the world here: every vertex is at distance 0, so every colour is the scale's first stop.
  const std::string colors = decodeBytes(data.at("scene").at("mesh").at("colors"));
  REQUIRE(colors.size() % 3 == 0);
  REQUIRE(!colors.empty());
  const json& first = legend.at("stops")[0];
  for (std::size_t i = 0; i < colors.size(); i += 3)
    for (std::size_t k = 0; k < 3; ++k) CHECK(int(static_cast<unsigned char>(colors[i + k])) == first[k].get<int>());
}

TEST_CASE("the page keeps its data inside its script element and escapes the title", "[report][html]") {
  const fs::path dir = writeExploreRun("vdbmap_report_html");
  json data = vdbmap::report::collectReportData(dir, {});
  data["title"] = "a <b>bold</b> run";
  const std::string page = vdbmap::report::renderReportHtml(data);
  // The run's command holds "</script>"; the page holds exactly the template's script elements.
  std::size_t closes = 0;
  for (std::size_t at = page.find("</script>"); at != std::string::npos; at = page.find("</script>", at + 1)) ++closes;
  CHECK(closes == 4);
  CHECK(page.find("<title>a &lt;b&gt;bold&lt;/b&gt; run</title>") != std::string::npos);
  CHECK(page.find("@DATA@") == std::string::npos);
  CHECK(page.find("data:text/javascript;base64,") != std::string::npos);
  CHECK(page.find("Copyright") != std::string::npos);  // three.js's licence travels with it
}

TEST_CASE("bench drift and bench alc folders become the Table II grid and per-seed bars", "[report][bench]") {
  const fs::path drift = fs::temp_directory_path() / "vdbmap_report_drift";
  fs::remove_all(drift);
  json table = json::array();
  for (const char* level : {"s1", "s3"})
    for (const char* mode : {"none", "keyframes"})
      table.push_back({{"level", level}, {"mode", mode},
                       {"accuracy_rmse_m", std::string(level) == "s1" ? 0.04 : (std::string(mode) == "none" ? 0.16 : 0.035)}});
  writeText(drift / "table.json", table.dump());
  const json d = vdbmap::report::collectReportData(drift, {});
  const json& grid = byId(d.at("tables"), "table2");
  CHECK(grid.at("columns") == json({"mode", "s1 RMSE (cm)", "s3 RMSE (cm)"}));
  CHECK(grid.at("rows")[0] == json({"none", 4.0, 16.0}));
  CHECK(grid.at("rows")[1] == json({"keyframes", 4.0, 3.5}));

  const fs::path alc = fs::temp_directory_path() / "vdbmap_report_alc";
  fs::remove_all(alc);
  json runs = json::array();
  for (const char* arm : {"no_alc", "alc"})
    for (int seed = 1; seed <= 2; ++seed)
      runs.push_back({{"arm", arm}, {"seed", seed}, {"accuracy_rmse_m", std::string(arm) == "alc" ? 0.07 : 0.2 * seed},
                      {"exploration_time_s", 200.0}, {"loop_closures", 3}, {"coverage", 0.99}, {"collisions", 0}});
  writeText(alc / "alc.json", runs.dump());
  const json a = vdbmap::report::collectReportData(alc, {});
  const json& rmse = byId(a.at("plots"), "accuracy_rmse_m");
  CHECK(rmse.at("categories") == json({"seed 1", "seed 2"}));
  CHECK(rmse.at("groups")[0].at("name") == "no_alc");
  CHECK(rmse.at("groups")[0].at("values") == json({0.2, 0.4}));
  CHECK(rmse.at("groups")[1].at("values") == json({0.07, 0.07}));

  // Several worlds: a case is a world and a seed.
  const fs::path worlds = fs::temp_directory_path() / "vdbmap_report_alc_worlds";
  fs::remove_all(worlds);
  json multi = json::array();
  for (const char* world : {"office1", "office2"})
    for (const char* arm : {"no_alc", "alc"})
      multi.push_back({{"world", world},
                       {"arm", arm},
                       {"seed", 1},
                       {"accuracy_rmse_m", std::string(world) == "office1" ? 0.1 : 0.2},
                       {"exploration_time_s", 200.0},
                       {"loop_closures", 3},
                       {"coverage", 0.99},
                       {"collisions", 0}});
  writeText(worlds / "alc.json", multi.dump());
  const json m = vdbmap::report::collectReportData(worlds, {});
  const json& per_case = byId(m.at("plots"), "accuracy_rmse_m");
  CHECK(per_case.at("categories") == json({"office1 seed 1", "office2 seed 1"}));
  CHECK(per_case.at("groups")[1].at("values") == json({0.1, 0.2}));
  CHECK(byId(m.at("tables"), "runs").at("rows")[2].at(0) == "office2");
}

TEST_CASE("malformed report inputs are named: the path, the file and line, the field", "[report][errors]") {
  const fs::path nothing = fs::temp_directory_path() / "vdbmap_report_nothing";
  fs::remove_all(nothing);
  fs::create_directories(nothing);
  CHECK_THROWS_WITH(vdbmap::report::collectReportData(nothing, {}),
                    Catch::Contains("vdbmap_report_nothing") && Catch::Contains("not a run to report on"));
  CHECK_THROWS_WITH(vdbmap::report::collectReportData(nothing / "missing", {}), Catch::Contains("does not exist"));

  const fs::path dir = writeExploreRun("vdbmap_report_badcsv");
  writeText(dir / "coverage.csv", "t_s,coverage,path_length_m,clusters,loop_closures,estimate_error_m,activity\n"
                                  "0.0,0.1,0,1,0,0,to_target\n0.5,abc,0,1,0,0,to_target\n");
  CHECK_THROWS_WITH(vdbmap::report::collectReportData(dir, {}),
                    Catch::Contains("coverage.csv:3") && Catch::Contains("coverage") && Catch::Contains("abc"));
  writeText(dir / "coverage.csv", "t_s,coverage\n0.0\n");
  CHECK_THROWS_WITH(vdbmap::report::collectReportData(dir, {}), Catch::Contains("coverage.csv:2") && Catch::Contains("1 fields"));
  writeText(dir / "summary.json", "{ not json");
  CHECK_THROWS_WITH(vdbmap::report::collectReportData(dir, {}), Catch::Contains("summary.json") && Catch::Contains("not valid JSON"));
  vdbmap::report::ReportConfig bad;
  bad.max_triangles = 10;
  CHECK_THROWS_AS(vdbmap::report::collectReportData(dir, bad), std::invalid_argument);
}
