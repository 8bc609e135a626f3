// `vdbmap report`: one self-contained HTML page of a run, to look at rather than read. The page
// holds its data (JSON), three.js (vendored, MIT) and its own script inline, so it opens offline
// from a file in any browser with WebGL: a 3D view of the map's mesh and the trajectories with a
// time slider and per-layer toggles, SVG plots of the run's time series, and tables.
//
// Inputs (detectInput): an `explore` run folder (summary.json, trajectories, coverage.csv,
// cycles.csv, mesh.ply or map.vdb, log/simulation.json), a `bench drift` folder (table.json and
// the level/mode meshes when written), a `bench alc` folder (alc.json and runs/), or a map (.vdb)
// with its `integrate --json` summary.
#pragma once

#include <nlohmann/json.hpp>

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace vdbmap::report {

enum class ReportInput { ExploreRun, DriftBenchmark, AlcBenchmark, Map };
const char* toString(ReportInput input);

/// What `path` is. Throws std::runtime_error naming the path and what was looked for when it is
/// none of the inputs.
ReportInput detectInput(const std::filesystem::path& path);

struct ReportConfig {
  /// Colour the mesh by its distance to this world mesh. Default: the world an `explore` run
  /// recorded (summary.json's "world", cut as it was), when that file exists; else by height.
  std::filesystem::path world;
  /// For a map: its `integrate --json` summary (default: MAP with the extension .json, if present).
  std::filesystem::path summary;
  std::size_t max_triangles = 400000;  ///< larger meshes are decimated (mesh_decimation.hpp); [1000, 1e8]
  std::size_t max_plot_points = 5000;  ///< longer series are thinned evenly; [100, 1e7]
  double error_scale_m = 0.2;          ///< the error colours saturate at this distance; (0, 100]
  std::string command;                 ///< the command that made the page, shown in its header

  void validate() const;
};

struct ReportStats {
  ReportInput input = ReportInput::ExploreRun;
  std::size_t bytes = 0;
  std::size_t mesh_triangles = 0;    ///< in the page
  std::size_t source_triangles = 0;  ///< before decimation
  bool coloured_by_error = false;
  std::vector<std::string> notes;    ///< what is missing from the page and why
};

/// The page's data, as its script reads it (see assets/report.js). Throws std::runtime_error
/// naming the file for unreadable or malformed inputs; std::invalid_argument for a bad config.
nlohmann::json collectReportData(const std::filesystem::path& input, const ReportConfig& config,
                                 ReportStats* stats = nullptr);

/// The whole page: the template with the data, the style, three.js and the script inlined.
std::string renderReportHtml(const nlohmann::json& data);

/// collectReportData + renderReportHtml, written atomically to `output` (a failure leaves a
/// previous page as it was).
ReportStats writeReport(const std::filesystem::path& input, const std::filesystem::path& output,
                        const ReportConfig& config);

}  // namespace vdbmap::report
