// `vdbmap drift-log DATASET -o LOG`: a copy of a dataset's listing with seeded odometry drift and
// a loop-closure correction event (see sim/log_drift.hpp for the generator).
#include "command.hpp"

#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/sim/log_drift.hpp"

#include <cstdio>
#include <filesystem>
#include <stdexcept>

namespace vdbmap::cli {
namespace {
const Registration registration("drift-log", [](CLI::App& app) {
  auto in = std::make_shared<std::filesystem::path>();
  auto out = std::make_shared<std::filesystem::path>();
  auto c = std::make_shared<sim::LogDriftConfig>();
  auto overwrite = std::make_shared<bool>(false);
  CLI::App* sub = app.add_subcommand(
      "drift-log", "Write a log whose poses drift (seeded random walk in translation and yaw) with a loop-closure "
                   "correction event holding the true poses where the camera returns near its start");
  sub->option_defaults()->always_capture_default();
  sub->add_option("dataset", *in, "Depth dataset or log with true poses")->required()->check(CLI::ExistingDirectory);
  sub->add_option("-o,--output", *out, "Log folder to write")->required();
  sub->add_option("--sigma-translation", c->sigma_translation_m, "Per-frame translation step, metres per axis");
  sub->add_option("--sigma-yaw-deg", c->sigma_yaw_deg, "Per-frame yaw step, degrees");
  sub->add_option("--seed", c->seed, "Random seed");
  sub->add_flag("--overwrite", *overwrite, "Replace a log already in the output folder");
  sub->callback([in, out, c, overwrite] {
    if (!*overwrite && std::filesystem::exists(*out / "frames.csv"))
      throw std::runtime_error(out->string() + " already holds a log (frames.csv); give --overwrite to replace it");
    const auto source = io::openDataset(*in);
    const sim::DriftedLog d = sim::writeDriftedLog(*source, *out, *c);
    std::printf("wrote %s: %zu frames, correction at frame %zu (%.2f m from the start), drift there %.3f m and "
                "%.2f deg\n", out->c_str(), d.frames, d.event_frame, d.loop_distance_m, d.drift_at_event_m,
                d.drift_at_event_deg);
  });
});
}  // namespace
}  // namespace vdbmap::cli
