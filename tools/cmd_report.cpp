// `vdbmap report PATH -o report.html [--world W.ply] [--summary S.json] [--max-triangles N]`: one
// self-contained HTML page of a run (tools/report/report.hpp).
#include "cli_util.hpp"
#include "command.hpp"

#include "report/report.hpp"
#include "vdbmap/timing.hpp"

#include <cstdio>

namespace vdbmap::cli {
namespace {

struct ReportOptions {
  std::filesystem::path input, output;
  report::ReportConfig config;
};

void runReport(const ReportOptions& o, const std::string& command) {
  report::ReportConfig config = o.config;
  config.command = command;
  const Stopwatch watch;
  const report::ReportStats s = report::writeReport(o.input, o.output, config);
  for (const std::string& note : s.notes) std::fprintf(stderr, "note: %s\n", note.c_str());
  std::printf("%s: report of the %s %s, %.1f MB, mesh %zu triangles (of %zu) coloured by %s, in %.1f s\n",
              o.output.c_str(), report::toString(s.input), o.input.c_str(), double(s.bytes) / 1e6, s.mesh_triangles,
              s.source_triangles, s.coloured_by_error ? "distance to the world" : "height", watch.s());
}

const Registration registration("report", [](CLI::App& app) {
  auto o = std::make_shared<ReportOptions>();
  CLI::App* sub = app.add_subcommand(
      "report", "Write one self-contained HTML page of a run (explore run folder, bench drift or bench alc folder, "
                "or a map): a 3D view of the map and the trajectories, plots of the run's time series, and tables");
  sub->option_defaults()->always_capture_default();
  sub->add_option("path", o->input, "An explore run folder, a bench drift or bench alc output folder, or a map (.vdb)")
      ->required();
  sub->add_option("-o,--output", o->output, "The page to write (.html)")->required();
  sub->add_option("--world", o->config.world,
                  "Colour the mesh by its distance to this world mesh (default: the world an explore run recorded, "
                  "when it exists; else by height)")
      ->check(CLI::ExistingFile);
  sub->add_option("--summary", o->config.summary, "For a map: its `integrate --json` summary (default: MAP.json beside it)")
      ->check(CLI::ExistingFile);
  sub->add_option("--max-triangles", o->config.max_triangles, "Decimate larger meshes to at most this many triangles")
      ->check(CLI::Range(std::size_t(1000), std::size_t(100000000)));
  sub->add_option("--error-scale", o->config.error_scale_m, "Distance (m) at which the error colours saturate")
      ->check(CLI::Range(1e-6, 100.0));
  sub->callback([o] { runReport(*o, "vdbmap report " + o->input.string() + " -o " + o->output.string()); });
});

}  // namespace
}  // namespace vdbmap::cli
