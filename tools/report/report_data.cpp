// The page's data: what each input holds, turned into the JSON that assets/report.js draws.
#include "report/report.hpp"

#include "report/base64.hpp"
#include "report/mesh_decimation.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/io/tum_trajectory.hpp"
#include "vdbmap/mesh.hpp"
#include "vdbmap/sim/world.hpp"
#include "vdbmap/timing.hpp"
#include "vdbmap/tsdf_volume.hpp"
#include "vdbmap/version.hpp"

#include <openvdb/version.h>
#include <sys/utsname.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <ctime>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <tuple>

namespace vdbmap::report {
namespace fs = std::filesystem;
using nlohmann::json;

const char* toString(ReportInput input) {
  switch (input) {
    case ReportInput::ExploreRun: return "explore run";
    case ReportInput::DriftBenchmark: return "bench drift";
    case ReportInput::AlcBenchmark: return "bench alc";
    case ReportInput::Map: return "map";
  }
  return "?";
}

ReportInput detectInput(const fs::path& path) {
  if (fs::is_regular_file(path) && path.extension() == ".vdb") return ReportInput::Map;
  if (fs::is_directory(path)) {
    if (fs::is_regular_file(path / "summary.json") && fs::is_regular_file(path / "trajectory_true.txt"))
      return ReportInput::ExploreRun;
    if (fs::is_regular_file(path / "table.json")) return ReportInput::DriftBenchmark;
    if (fs::is_regular_file(path / "alc.json")) return ReportInput::AlcBenchmark;
  }
  throw std::runtime_error(path.string() + (fs::exists(path) ? "" : " does not exist") +
                           (fs::exists(path) ? ": not a run to report on; expected an explore run folder (summary.json "
                                               "+ trajectory_true.txt), a bench drift folder (table.json), a bench "
                                               "alc folder (alc.json) or a map (.vdb)"
                                             : ""));
}

void ReportConfig::validate() const {
  if (max_triangles < 1000 || max_triangles > 100000000)
    throw std::invalid_argument("ReportConfig.max_triangles must be in [1000, 1e8]");
  if (max_plot_points < 100 || max_plot_points > 10000000)
    throw std::invalid_argument("ReportConfig.max_plot_points must be in [100, 1e7]");
  if (!(error_scale_m > 0.0 && error_scale_m <= 100.0))
    throw std::invalid_argument("ReportConfig.error_scale_m must be in (0, 100]");
}

namespace {

// ---- encoding ----------------------------------------------------------------------------------

template <typename T>
std::string base64(const std::vector<T>& v) {
  return report::base64(v.data(), v.size() * sizeof(T));
}

/// A number with about 5 significant digits, so that the page stays small.
double rounded(double v) {
  if (!std::isfinite(v) || v == 0.0) return std::isfinite(v) ? 0.0 : v;
  const double scale = std::pow(10.0, 4 - int(std::floor(std::log10(std::fabs(v)))));
  return std::round(v * scale) / scale;
}

json numbers(const std::vector<double>& v) {
  json a = json::array();
  for (double x : v) a.push_back(std::isfinite(x) ? json(rounded(x)) : json(nullptr));
  return a;
}

// ---- reading -----------------------------------------------------------------------------------

json readJson(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path.string() + ": cannot open");
  try {
    return json::parse(in);
  } catch (const json::exception& e) {
    throw std::runtime_error(path.string() + ": not valid JSON (" + e.what() + ")");
  }
}

/// A CSV with a header line: columns by name, every cell a number except those in `text_columns`.
struct Csv {
  std::map<std::string, std::vector<double>> numbers;
  std::map<std::string, std::vector<std::string>> text;
  std::size_t rows = 0;
};

Csv readCsv(const fs::path& path, const std::vector<std::string>& text_columns = {}) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path.string() + ": cannot open");
  std::string line;
  std::vector<std::string> header;
  const auto split = [](const std::string& s) {
    std::vector<std::string> cells;
    std::stringstream ss(s);
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    return cells;
  };
  if (!std::getline(in, line)) throw std::runtime_error(path.string() + ": empty (no header line)");
  header = split(line);
  Csv csv;
  std::size_t line_number = 1;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty()) continue;
    const std::vector<std::string> cells = split(line);
    if (cells.size() != header.size())
      throw std::runtime_error(path.string() + ":" + std::to_string(line_number) + ": " +
                               std::to_string(cells.size()) + " fields, the header has " +
                               std::to_string(header.size()));
    for (std::size_t c = 0; c < header.size(); ++c) {
      if (std::find(text_columns.begin(), text_columns.end(), header[c]) != text_columns.end()) {
        csv.text[header[c]].push_back(cells[c]);
        continue;
      }
      char* end = nullptr;
      const double v = std::strtod(cells[c].c_str(), &end);
      if (cells[c].empty() || *end != '\0')
        throw std::runtime_error(path.string() + ":" + std::to_string(line_number) + ": field " + header[c] +
                                 " is not a number: '" + cells[c] + "'");
      csv.numbers[header[c]].push_back(v);
    }
    ++csv.rows;
  }
  return csv;
}

const std::vector<double>& column(const Csv& csv, const fs::path& path, const std::string& name) {
  const auto it = csv.numbers.find(name);
  if (it == csv.numbers.end()) throw std::runtime_error(path.string() + ": no column " + name);
  return it->second;
}

/// Every k-th index so that at most max_points remain (the last always kept).
std::vector<std::size_t> thinned(std::size_t n, std::size_t max_points) {
  std::vector<std::size_t> idx;
  const std::size_t step = std::max<std::size_t>(1, (n + max_points - 1) / max_points);
  for (std::size_t i = 0; i < n; i += step) idx.push_back(i);
  if (n > 0 && idx.back() != n - 1) idx.push_back(n - 1);
  return idx;
}

// ---- page pieces -------------------------------------------------------------------------------

json series(const std::string& name, const std::vector<double>& x, const std::vector<double>& y, std::size_t max_points,
            const std::string& style = "line") {
  std::vector<double> xs, ys;
  for (std::size_t i : thinned(x.size(), max_points)) {
    xs.push_back(x[i]);
    ys.push_back(y[i]);
  }
  return {{"name", name}, {"x", numbers(xs)}, {"y", numbers(ys)}, {"style", style}};
}

json plot(const std::string& id, const std::string& title, const std::string& x_label, const std::string& y_label,
          json series_list, json marks = json::array()) {
  return {{"id", id}, {"kind", "xy"}, {"title", title}, {"x_label", x_label}, {"y_label", y_label},
          {"series", std::move(series_list)}, {"marks", std::move(marks)}};
}

/// Grouped bars: one group of bars per category, one bar per group name.
json bars(const std::string& id, const std::string& title, const std::string& y_label,
          const std::vector<std::string>& categories, const std::vector<std::pair<std::string, std::vector<double>>>& groups) {
  json g = json::array();
  for (const auto& [name, values] : groups) g.push_back({{"name", name}, {"values", numbers(values)}});
  return {{"id", id}, {"kind", "bars"}, {"title", title}, {"y_label", y_label}, {"categories", categories}, {"groups", g}};
}

json figure(const std::string& label, const json& value, const std::string& unit = "") {
  return {{"label", label}, {"value", value.is_number_float() ? json(rounded(value.get<double>())) : value}, {"unit", unit}};
}

/// The machine and the versions, for the header.
json provenance(const std::string& command) {
  utsname u{};
  std::string machine = "unknown";
  if (::uname(&u) == 0) machine = std::string(u.sysname) + " " + u.release + " " + u.machine;
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line, cpu;
  while (cpu.empty() && std::getline(cpuinfo, line))
    if (line.rfind("model name", 0) == 0) cpu = line.substr(line.find(':') + 2);
  char when[64] = "";
  const std::time_t now = std::time(nullptr);
  std::strftime(when, sizeof(when), "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&now));
  return {{"command", command},
          {"versions", {{"vdbmap", VDBMAP_VERSION_STRING}, {"OpenVDB", openvdb::getLibraryVersionString()},
                        {"three.js", "0.170.0"}, {"compiler", __VERSION__}}},
          {"machine", machine + (cpu.empty() ? "" : ", " + cpu) + ", " +
                          std::to_string(std::thread::hardware_concurrency()) + " hardware threads"},
          {"generated", when}};
}

// ---- the 3D scene ------------------------------------------------------------------------------

/// Blue (0) -> green -> yellow -> red (1).
std::array<std::uint8_t, 3> ramp(double u) {
  static const double stops[][3] = {{0.19, 0.33, 0.80}, {0.15, 0.68, 0.38}, {0.95, 0.80, 0.20}, {0.85, 0.15, 0.13}};
  u = std::clamp(u, 0.0, 1.0) * 3.0;
  const int i = std::min(int(u), 2);
  const double f = u - i;
  std::array<std::uint8_t, 3> c{};
  for (int k = 0; k < 3; ++k) c[std::size_t(k)] = std::uint8_t(std::lround(255.0 * ((1 - f) * stops[i][k] + f * stops[i + 1][k])));
  return c;
}
json rampLegend(const std::string& label, double lo, double hi) {
  json stops = json::array();
  for (int i = 0; i <= 4; ++i) {
    const auto c = ramp(i / 4.0);
    stops.push_back({c[0], c[1], c[2]});
  }
  return {{"label", label}, {"min", rounded(lo)}, {"max", rounded(hi)}, {"stops", stops}};
}

/// The mesh layer: decimated to the budget, coloured by distance to `world` (when given) or by height.
json meshLayer(const TriangleMesh& source, double voxel_size_m, const sim::World* world, const ReportConfig& config,
               ReportStats& stats) {
  const TriangleMesh mesh = decimateToBudget(source, config.max_triangles, voxel_size_m);
  stats.source_triangles = source.triangles.size();
  stats.mesh_triangles = mesh.triangles.size();
  std::vector<float> positions;
  positions.reserve(mesh.vertices.size() * 3);
  for (const Vec3f& v : mesh.vertices) positions.insert(positions.end(), {v.x(), v.y(), v.z()});
  std::vector<std::uint32_t> indices;
  indices.reserve(mesh.triangles.size() * 3);
  for (const Eigen::Vector3i& t : mesh.triangles)
    indices.insert(indices.end(), {std::uint32_t(t[0]), std::uint32_t(t[1]), std::uint32_t(t[2])});
  std::vector<double> value(mesh.vertices.size());
  json legend;
  if (world) {
    const double cap = 5.0 * config.error_scale_m;
    tbb::parallel_for(std::size_t(0), mesh.vertices.size(),
                      [&](std::size_t i) { value[i] = world->distance(mesh.vertices[i].cast<double>(), cap); });
    legend = rampLegend("distance to the world (m)", 0.0, config.error_scale_m);
    for (double& v : value) v /= config.error_scale_m;
    stats.coloured_by_error = true;
  } else {
    double lo = 0.0, hi = 1.0;
    if (!mesh.vertices.empty()) {
      std::vector<double> z;
      for (const Vec3f& v : mesh.vertices) z.push_back(v.z());
      std::sort(z.begin(), z.end());
      lo = z[z.size() / 100];
      hi = std::max(z[z.size() - 1 - z.size() / 100], lo + 1e-3);
    }
    for (std::size_t i = 0; i < value.size(); ++i) value[i] = (mesh.vertices[i].z() - lo) / (hi - lo);
    legend = rampLegend("height (m)", lo, hi);
  }
  std::vector<std::uint8_t> colors;
  colors.reserve(value.size() * 3);
  for (double v : value) {
    const auto c = ramp(v);
    colors.insert(colors.end(), c.begin(), c.end());
  }
  return {{"positions", base64(positions)}, {"indices", base64(indices)}, {"colors", base64(colors)},
          {"triangles", mesh.triangles.size()}, {"source_triangles", source.triangles.size()},
          {"legend", legend}};
}

struct Track {
  std::vector<double> t;
  std::vector<Vec3d> p;
  /// The position at time t_s (the nearest sample at or before it).
  Vec3d at(double t_s) const {
    const auto it = std::upper_bound(t.begin(), t.end(), t_s);
    return p[std::size_t(std::max<std::ptrdiff_t>(0, (it - t.begin()) - 1))];
  }
};

Track readTrack(const fs::path& path) {
  Track track;
  for (const io::StampedPose& s : io::readTumTrajectory(path)) {
    track.t.push_back(s.timestamp_s);
    track.p.push_back(s.T_W_S.translation());
  }
  return track;
}

json lineLayer(const std::string& name, const std::string& color, const Track& track, bool visible = true) {
  std::vector<float> xyz, t;
  for (std::size_t i = 0; i < track.p.size(); ++i) {
    xyz.insert(xyz.end(), {float(track.p[i].x()), float(track.p[i].y()), float(track.p[i].z())});
    t.push_back(float(track.t[i]));
  }
  return {{"name", name}, {"color", color}, {"xyz", base64(xyz)}, {"t", base64(t)}, {"visible", visible}};
}

/// Segments a-b (each with the time it appears), e.g. loop-closure edges.
json segmentLayer(const std::string& name, const std::string& color, const std::vector<std::pair<Vec3d, Vec3d>>& segments,
                  const std::vector<double>& times) {
  std::vector<float> xyz, t;
  for (std::size_t i = 0; i < segments.size(); ++i) {
    for (const Vec3d& p : {segments[i].first, segments[i].second})
      xyz.insert(xyz.end(), {float(p.x()), float(p.y()), float(p.z())});
    t.push_back(float(times[i]));
  }
  return {{"name", name}, {"color", color}, {"xyz", base64(xyz)}, {"t", base64(t)}, {"visible", true}};
}

json pointLayer(const std::string& name, const std::string& color, double radius_m, const std::vector<Vec3d>& points,
                const std::vector<double>& times) {
  json p = json::array();
  for (std::size_t i = 0; i < points.size(); ++i)
    p.push_back({{"xyz", {rounded(points[i].x()), rounded(points[i].y()), rounded(points[i].z())}},
                 {"t", rounded(times[i])}});
  return {{"name", name}, {"color", color}, {"radius_m", radius_m}, {"points", p}, {"visible", true}};
}

sim::World loadWorld(const fs::path& path, const json& summary) {
  sim::WorldConfig wc;
  if (summary.contains("world_ceiling")) {
    wc.ceiling_clip_z_m = summary["world_ceiling"].value("clip_z_m", wc.ceiling_clip_z_m);
    wc.cap_ceiling = summary["world_ceiling"].value("capped", false);
  }
  return sim::World::load(path, wc);
}

/// The world to colour by: the config's, else the one the summary recorded (when it exists).
std::optional<sim::World> worldFor(const ReportConfig& config, const json& summary, ReportStats& stats) {
  if (!config.world.empty()) return loadWorld(config.world, summary);
  if (summary.contains("world")) {
    const fs::path recorded = summary["world"].get<std::string>();
    if (fs::is_regular_file(recorded)) return loadWorld(recorded, summary);
    stats.notes.push_back("the run's world " + recorded.string() + " is not here: the mesh is coloured by height");
  }
  return std::nullopt;
}

// ---- inputs ------------------------------------------------------------------------------------

json exploreRun(const fs::path& dir, const ReportConfig& config, ReportStats& stats) {
  const json summary = readJson(dir / "summary.json");
  json data;
  data["kind"] = "explore";
  data["title"] = "Exploration run " + dir.filename().string();
  data["header"] = provenance(config.command.empty() ? summary.value("description", std::string()) : config.command);
  data["header"]["run_command"] = summary.value("description", std::string());

  const Track truth = readTrack(dir / "trajectory_true.txt");
  const Track estimate = readTrack(dir / "trajectory_odom.txt");
  if (truth.t.empty()) throw std::runtime_error((dir / "trajectory_true.txt").string() + ": no poses");
  const double t_end = truth.t.back();

  // Figures.
  json figures = json::array();
  const auto add = [&](const std::string& label, const char* key, const std::string& unit = "") {
    if (summary.contains(key) && !summary[key].is_null()) figures.push_back(figure(label, summary[key], unit));
  };
  add("finished", "finished");
  add("exploration time", "exploration_time_s", "s");
  add("coverage at finish", "coverage");
  add("path length", "path_length_m", "m");
  add("mean speed", "mean_speed_mps", "m/s");
  if (summary.contains("time_to_coverage_s") && summary["time_to_coverage_s"].contains("0.95"))
    figures.push_back(figure("time to 0.95 coverage", summary["time_to_coverage_s"]["0.95"], "s"));
  add("loop closures", "loop_closures");
  add("collision events", "collisions");
  add("closest approach", "min_clearance_m", "m");
  add("map RMSE vs world", "accuracy_rmse_m", "m");
  add("map RMSE after the 4-DOF alignment", "accuracy_aligned_rmse_m", "m");
  add("completeness", "completeness");
  add("estimate error RMSE", "estimate_error_rmse_m", "m");
  add("drift mode / mapper", "mode");
  add("ALC detours", "alc_detours");
  add("planner median per replan", "planner_ms_median", "ms");
  add("planner max per replan", "planner_ms_max", "ms");
  add("mapper cycle p99", "ms_per_frame_p99", "ms");
  add("wall time", "wall_s", "s");
  data["figures"] = figures;
  if (summary.contains("activity_time_s")) data["activity_time_s"] = summary["activity_time_s"];

  // Events.
  std::vector<double> loop_t, collision_t, detour_t, visit_failed_t;
  for (const json& e : summary.value("events", json::array())) {
    const std::string what = e.value("what", "");
    const double t = e.value("t_s", 0.0);
    if (what == "loop_closure") loop_t.push_back(t);
    if (what == "collision") collision_t.push_back(t);
    if (what == "alc_detour") detour_t.push_back(t);
    if (what == "visit_failed") visit_failed_t.push_back(t);
  }
  json loop_marks = json::array();
  for (double t : loop_t) loop_marks.push_back({{"x", rounded(t)}, {"label", "loop closure"}});

  // The scene.
  json scene;
  scene["t_max"] = rounded(t_end);
  scene["lines"] = json::array({lineLayer("true trajectory", "#1f77b4", truth), lineLayer("estimated trajectory", "#ff7f0e", estimate)});
  scene["segments"] = json::array();
  scene["points"] = json::array();
  if (summary.contains("start") && summary["start"].size() >= 3)
    scene["points"].push_back(pointLayer("start", "#2ca02c", 0.25,
                                         {Vec3d(summary["start"][0], summary["start"][1], summary["start"][2])}, {0.0}));
  // Events where the true path was when they happened.
  const auto eventLayer = [&](const char* name, const char* colour, double size, const std::vector<double>& times) {
    std::vector<Vec3d> at;
    for (double t : times) at.push_back(truth.at(t));
    return pointLayer(name, colour, size, at, times);
  };
  scene["points"].push_back(eventLayer("collisions", "#d62728", 0.3, collision_t));
  scene["points"].push_back(eventLayer("ALC detour starts", "#9467bd", 0.2, detour_t));
  scene["points"].push_back(eventLayer("failed visits", "#8c564b", 0.15, visit_failed_t));

  const fs::path simulation = dir / "log" / "simulation.json";
  if (fs::is_regular_file(simulation)) {
    const json sim = readJson(simulation);
    std::vector<std::pair<Vec3d, Vec3d>> edges;
    std::vector<double> edge_t;
    for (const json& lc : sim.value("loop_closures", json::array())) {
      const std::size_t a = lc.value("new_frame", std::size_t(0)), b = lc.value("old_frame", std::size_t(0));
      if (a >= truth.p.size() || b >= truth.p.size())
        throw std::runtime_error(simulation.string() + ": loop closure names frame " + std::to_string(std::max(a, b)) +
                                 ", the trajectory has " + std::to_string(truth.p.size()));
      edges.emplace_back(truth.p[a], truth.p[b]);
      edge_t.push_back(lc.value("t_s", truth.t[a]));
    }
    scene["segments"].push_back(segmentLayer("loop-closure edges", "#e377c2", edges, edge_t));
  } else {
    stats.notes.push_back("no log/simulation.json: loop-closure edges are not drawn");
  }

  // Time series.
  json plots = json::array();
  const fs::path coverage_csv = dir / "coverage.csv";
  if (fs::is_regular_file(coverage_csv)) {
    const Csv c = readCsv(coverage_csv, {"activity"});
    const std::vector<double>& t = column(c, coverage_csv, "t_s");
    json lines = json::array({series("coverage", t, column(c, coverage_csv, "coverage"), config.max_plot_points)});
    // What the camera saw at the true poses (runs before stop 63 lack the column): the gap
    // between the two lines is what drift put elsewhere in the map.
    if (c.numbers.count("coverage_seen"))
      lines.push_back(
          series("seen by the camera", t, column(c, coverage_csv, "coverage_seen"), config.max_plot_points));
    plots.push_back(
        plot("coverage", "Coverage of the observable surface", "time (s)", "coverage", std::move(lines), loop_marks));
  } else {
    stats.notes.push_back("no coverage.csv (a run made before it was written): no coverage plot");
  }
  std::vector<double> error(truth.t.size());
  if (estimate.p.size() != truth.p.size())
    throw std::runtime_error((dir / "trajectory_odom.txt").string() + ": " + std::to_string(estimate.p.size()) +
                             " poses, trajectory_true.txt has " + std::to_string(truth.p.size()));
  for (std::size_t i = 0; i < error.size(); ++i) error[i] = (truth.p[i] - estimate.p[i]).norm();
  plots.push_back(plot("estimate_error", "Estimate error (estimated vs true sensor position)", "time (s)", "error (m)",
                       json::array({series("error", truth.t, error, config.max_plot_points)}), loop_marks));

  const fs::path cycles_csv = dir / "cycles.csv";
  if (fs::is_regular_file(cycles_csv)) {
    const Csv c = readCsv(cycles_csv, {"activity", "replan"});
    const std::vector<double>& t = column(c, cycles_csv, "t_s");
    const std::vector<double>& planner_ms = column(c, cycles_csv, "planner_ms");
    std::vector<double> replan_t, replan_ms;
    for (std::size_t i = 0; i < t.size(); ++i)
      if (planner_ms[i] > 0.0) {
        replan_t.push_back(t[i]);
        replan_ms.push_back(planner_ms[i]);
      }
    json planner_series = json::array({series("replan", replan_t, replan_ms, config.max_plot_points, "points")});
    if (c.numbers.count("update_ms"))  // runs before stop 73 lack it
      planner_series.push_back(
          series("whole update, every frame", t, column(c, cycles_csv, "update_ms"), config.max_plot_points));
    plots.push_back(plot("planner_ms", "Planner time per replan and per frame (wall clock)", "time (s)", "ms",
                         std::move(planner_series)));
    plots.push_back(plot("cycle_ms", "Mapper cycle per frame (integration, corrections, background)", "time (s)", "ms",
                         json::array({series("mapper cycle", t, column(c, cycles_csv, "mapper_ms"), config.max_plot_points)}),
                         loop_marks));
    plots.push_back(plot("queue", "Re-integration work queued after each cycle", "time (s)", "frames",
                         json::array({series("queued frames", t, column(c, cycles_csv, "queued_frames"), config.max_plot_points)}),
                         loop_marks));
    // ALC detours as segments of the true path.
    std::vector<std::pair<Vec3d, Vec3d>> detour_segments;
    std::vector<double> detour_seg_t;
    const std::vector<std::string>& activity = c.text.at("activity");
    for (std::size_t i = 0; i + 1 < t.size() && i + 1 < truth.p.size(); ++i)
      if (activity[i] == "loop_detour") {
        detour_segments.emplace_back(truth.p[i], truth.p[i + 1]);
        detour_seg_t.push_back(t[i]);
      }
    scene["segments"].push_back(segmentLayer("ALC detours (true path)", "#9467bd", detour_segments, detour_seg_t));
  } else {
    stats.notes.push_back("no cycles.csv (a run made before it was written): no per-frame plots");
  }
  data["plots"] = plots;

  // The map.
  const std::optional<sim::World> world = worldFor(config, summary, stats);
  const double voxel = summary.value("voxel_size_m", 0.1);
  if (fs::is_regular_file(dir / "mesh.ply")) {
    scene["mesh"] = meshLayer(io::readTriangleMesh(dir / "mesh.ply"), voxel, world ? &*world : nullptr, config, stats);
  } else if (fs::is_regular_file(dir / "map.vdb")) {
    scene["mesh"] = meshLayer(extractMesh(TsdfVolume::load(dir / "map.vdb")), voxel, world ? &*world : nullptr, config, stats);
  } else {
    stats.notes.push_back("no mesh.ply or map.vdb: the 3D view shows the trajectories only");
  }
  data["scene"] = scene;
  return data;
}

json driftBenchmark(const fs::path& dir, const ReportConfig& config, ReportStats& stats) {
  const json table = readJson(dir / "table.json");
  if (!table.is_array() || table.empty()) throw std::runtime_error((dir / "table.json").string() + ": no rows");
  std::vector<std::string> levels, modes;
  std::map<std::pair<std::string, std::string>, json> cell;
  for (const json& r : table) {
    const std::string level = r.at("level"), mode = r.at("mode");
    if (std::find(levels.begin(), levels.end(), level) == levels.end()) levels.push_back(level);
    if (std::find(modes.begin(), modes.end(), mode) == modes.end()) modes.push_back(mode);
    cell[{level, mode}] = r;
  }
  json data;
  data["kind"] = "bench_drift";
  data["title"] = "Map accuracy under drift (Table II) " + dir.filename().string();
  data["header"] = provenance(config.command);
  std::vector<std::pair<std::string, std::vector<double>>> groups;
  json rows = json::array();
  for (const std::string& mode : modes) {
    std::vector<double> rmse_cm;
    json row = json::array({mode});
    for (const std::string& level : levels) {
      const auto it = cell.find({level, mode});
      const double v = it == cell.end() ? NAN : 100.0 * it->second.value("accuracy_rmse_m", NAN);
      rmse_cm.push_back(v);
      row.push_back(std::isfinite(v) ? json(rounded(v)) : json(nullptr));
    }
    groups.emplace_back(mode, rmse_cm);
    rows.push_back(row);
  }
  json columns = json::array({"mode"});
  for (const std::string& level : levels) columns.push_back(level + " RMSE (cm)");
  data["tables"] = json::array({{{"id", "table2"}, {"title", "Map RMSE against the world (cm), per drift level"},
                                 {"columns", columns}, {"rows", rows},
                                 {"note", "The paper's Table II values are not in this repository, so they are not shown beside these."}}});
  json detail = json::array();
  for (const json& r : table)
    detail.push_back({r.value("level", ""), r.value("mode", ""), rounded(100.0 * r.value("accuracy_rmse_m", NAN)),
                      rounded(r.value("completeness", NAN)), r.value("keyframes_kept", 0), r.value("frames_total", 0),
                      r.value("reintegrated_frames", 0), rounded(r.value("wall_s", NAN))});
  data["tables"].push_back({{"id", "rows"}, {"title", "Every row"},
                            {"columns", {"level", "mode", "RMSE (cm)", "completeness", "frames kept", "frames",
                                         "re-integrated", "wall (s)"}},
                            {"rows", detail}});
  data["plots"] = json::array({bars("rmse", "Map RMSE per drift level and mode", "RMSE (cm)", levels, groups)});
  data["figures"] = json::array({figure("drift levels", levels.size()), figure("modes", modes.size())});
  json scene;
  scene["lines"] = json::array();
  scene["segments"] = json::array();
  scene["points"] = json::array();
  scene["t_max"] = 0.0;
  // The most drifted level's map in the best-known mode, when the meshes were written.
  std::string shown_mode = std::find(modes.begin(), modes.end(), "keyframes") != modes.end() ? "keyframes" : modes.front();
  const fs::path mesh_file = dir / levels.back() / (shown_mode + ".ply");
  if (fs::is_regular_file(mesh_file)) {
    const std::optional<sim::World> world = config.world.empty() ? std::nullopt : std::optional<sim::World>(loadWorld(config.world, {}));
    scene["mesh"] = meshLayer(io::readTriangleMesh(mesh_file), 0.05, world ? &*world : nullptr, config, stats);
    scene["caption"] = "map of level " + levels.back() + ", mode " + shown_mode;
  } else {
    stats.notes.push_back("no " + mesh_file.string() + ": no 3D view (bench drift writes them unless --no-meshes)");
  }
  data["scene"] = scene;
  return data;
}

json alcBenchmark(const fs::path& dir, const ReportConfig& config, ReportStats& stats) {
  const json runs = readJson(dir / "alc.json");
  if (!runs.is_array() || runs.empty()) throw std::runtime_error((dir / "alc.json").string() + ": no runs");
  // A case is a world and a seed ("seed k" alone for a single world, or for folders written before
  // bench alc took several worlds, whose runs have no "world" and live in runs/<arm>_seed<k>).
  std::vector<std::string> arms, cases;
  std::map<std::pair<std::string, std::string>, json> by;
  std::set<std::string> worlds;
  for (const json& r : runs) worlds.insert(r.value("world", ""));
  const auto caseOf = [&](const json& r) {
    const std::string seed = "seed " + std::to_string(r.at("seed").get<long long>());
    return worlds.size() > 1 ? r.value("world", "") + " " + seed : seed;
  };
  for (const json& r : runs) {
    const std::string arm = r.at("arm"), c = caseOf(r);
    if (std::find(arms.begin(), arms.end(), arm) == arms.end()) arms.push_back(arm);
    if (std::find(cases.begin(), cases.end(), c) == cases.end()) cases.push_back(c);
    by[{arm, c}] = r;
  }
  json data;
  data["kind"] = "bench_alc";
  data["title"] = "Active loop closure, with and without " + dir.filename().string();
  data["header"] = provenance(config.command);
  json plots = json::array();
  const std::vector<std::pair<std::string, std::string>> metrics = {{"accuracy_rmse_m", "Map RMSE (m)"},
                                                                    {"exploration_time_s", "Exploration time (s)"},
                                                                    {"loop_closures", "Loop closures"},
                                                                    {"coverage", "Coverage at finish"},
                                                                    {"collisions", "Collision events"}};
  for (const auto& [key, title] : metrics) {
    std::vector<std::pair<std::string, std::vector<double>>> groups;
    for (const std::string& arm : arms) {
      std::vector<double> v;
      for (const std::string& c : cases) {
        const auto it = by.find({arm, c});
        v.push_back(it == by.end() ? NAN : it->second.value(key, NAN));
      }
      groups.emplace_back(arm, v);
    }
    plots.push_back(bars(key, title + (worlds.size() > 1 ? " per world and seed" : " per seed"), title, cases, groups));
  }
  data["plots"] = plots;
  json rows = json::array();
  for (const json& r : runs)
    rows.push_back({r.value("world", ""), r.value("arm", ""), r.value("seed", 0),
                    rounded(r.value("exploration_time_s", NAN)), rounded(r.value("accuracy_rmse_m", NAN)),
                    r.value("loop_closures", 0), rounded(r.value("coverage", NAN)), r.value("collisions", 0),
                    r.value("finished", false)});
  data["tables"] = json::array(
      {{{"id", "runs"},
        {"title", "Every run"},
        {"columns", {"world", "arm", "seed", "time (s)", "RMSE (m)", "loops", "coverage", "collisions", "finished"}},
        {"rows", rows}}});
  data["figures"] =
      json::array({figure("worlds", worlds.size()), figure("cases", cases.size()), figure("arms", arms.size())});
  json scene;
  scene["lines"] = json::array();
  scene["segments"] = json::array();
  scene["points"] = json::array();
  double t_max = 0.0;
  const char* colors[] = {"#1f77b4", "#ff7f0e"};
  const json& first = runs.front();
  const std::string first_world = first.value("world", ""),
                    first_seed = std::to_string(first.at("seed").get<long long>());
  for (std::size_t a = 0; a < arms.size() && a < 2; ++a) {
    const fs::path traj = (first_world.empty() ? dir / "runs" : dir / "runs" / first_world) /
                          (arms[a] + "_seed" + first_seed) / "trajectory_true.txt";
    if (!fs::is_regular_file(traj)) continue;
    const Track track = readTrack(traj);
    if (!track.t.empty()) t_max = std::max(t_max, track.t.back());
    scene["lines"].push_back(lineLayer("true trajectory, " + arms[a] + ", " + caseOf(first), colors[a], track));
  }
  if (scene["lines"].empty()) stats.notes.push_back("no runs/[<world>/]<arm>_seed<k>/trajectory_true.txt: no 3D view");
  scene["t_max"] = rounded(t_max);
  data["scene"] = scene;
  return data;
}

json mapInput(const fs::path& map, const ReportConfig& config, ReportStats& stats) {
  json summary = json::object();
  fs::path summary_path = config.summary;
  if (summary_path.empty() && fs::is_regular_file(fs::path(map).replace_extension(".json")))
    summary_path = fs::path(map).replace_extension(".json");
  if (!summary_path.empty()) summary = readJson(summary_path);
  else stats.notes.push_back("no integrate summary (--summary, or MAP.json beside the map): figures from the map only");
  const TsdfVolume volume = TsdfVolume::load(map);
  json data;
  data["kind"] = "map";
  data["title"] = "Map " + map.filename().string();
  data["header"] = provenance(config.command);
  json figures = json::array();
  figures.push_back(figure("voxel size", volume.config().voxel_size_m, "m"));
  figures.push_back(figure("active voxels", volume.activeVoxelCount()));
  for (const auto& [key, label, unit] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"log", "log", ""}, {"mode", "mode", ""}, {"frames_integrated", "frames integrated", ""},
           {"ms_per_frame_median", "integration per frame, median", "ms"}, {"ms_per_frame_p99", "cycle p99", "ms"},
           {"ms_per_frame_max", "cycle max", "ms"}, {"keyframes_kept", "keyframes kept", ""},
           {"correction_events", "correction events", ""}, {"wall_s", "wall time", "s"}})
    if (summary.contains(key)) figures.push_back(figure(label, summary[key], unit));
  data["figures"] = figures;
  json plots = json::array();
  if (summary.contains("cycle_ms") && summary["cycle_ms"].is_array() && !summary["cycle_ms"].empty()) {
    const std::vector<double> ms = summary["cycle_ms"].get<std::vector<double>>();
    std::vector<double> index(ms.size());
    for (std::size_t i = 0; i < ms.size(); ++i) index[i] = double(i);
    plots.push_back(plot("cycle_ms", "Cycle per frame (integration, corrections, background)", "frame", "ms",
                         json::array({series("cycle", index, ms, config.max_plot_points)})));
  }
  data["plots"] = plots;
  json scene;
  scene["lines"] = json::array();
  scene["segments"] = json::array();
  scene["points"] = json::array();
  scene["t_max"] = 0.0;
  const std::optional<sim::World> world = config.world.empty() ? std::nullopt : std::optional<sim::World>(loadWorld(config.world, {}));
  scene["mesh"] = meshLayer(extractMesh(volume), volume.config().voxel_size_m, world ? &*world : nullptr, config, stats);
  data["scene"] = scene;
  return data;
}

}  // namespace

json collectReportData(const fs::path& input, const ReportConfig& config, ReportStats* stats_out) {
  config.validate();
  ReportStats stats;
  stats.input = detectInput(input);
  json data;
  switch (stats.input) {
    case ReportInput::ExploreRun: data = exploreRun(input, config, stats); break;
    case ReportInput::DriftBenchmark: data = driftBenchmark(input, config, stats); break;
    case ReportInput::AlcBenchmark: data = alcBenchmark(input, config, stats); break;
    case ReportInput::Map: data = mapInput(input, config, stats); break;
  }
  data["notes"] = stats.notes;
  data["source"] = fs::absolute(input).lexically_normal().string();
  if (stats_out) *stats_out = stats;
  return data;
}

ReportStats writeReport(const fs::path& input, const fs::path& output, const ReportConfig& config) {
  ReportStats stats;
  const json data = collectReportData(input, config, &stats);
  const std::string html = renderReportHtml(data);
  writeFileAtomically(output, [&](std::ostream& os) { os << html; });
  stats.bytes = html.size();
  return stats;
}

}  // namespace vdbmap::report
