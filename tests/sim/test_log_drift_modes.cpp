// Loop-closure correction on real data: the 7-Scenes RedKitchen frames with seeded odometry drift
// (sim/log_drift.hpp) and one correction event where the camera returns near its start, replayed
// in every consistency mode and compared with the map integrated at the true poses.
#include "vdbmap/eval.hpp"
#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/log_replay.hpp"
#include "vdbmap/mesh.hpp"
#include "vdbmap/sim/log_drift.hpp"

#include "common/shared_data.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <map>

using namespace vdbmap;
namespace fs = std::filesystem;

namespace {
const fs::path kRedKitchen = vdbmap::test::sharedDataDir() / "7scenes_redkitchen_tsdf_fusion_python";

constexpr double kVoxel_m = 0.05;
constexpr int kStride = 4;  // 125 of the 500 frames keep the test quick; the drift and the loop are the same

MapperConfig configFor(ConsistencyMode mode, const io::SensorInfo& sensor) {
  MapperConfig c;
  c.mode = mode;
  c.tsdf.voxel_size_m = kVoxel_m;
  c.integrator.min_range_m = sensor.min_range_m;
  c.integrator.max_range_m = sensor.max_range_m;
  return c;
}

struct ModeRun {
  SurfaceEval eval;
  std::size_t kept = 0;
  std::size_t correction_events = 0;
};
}  // namespace

TEST_CASE("after a loop correction keyframes and all match the true-pose map and none does not", "[drift][shared]") {
  vdbmap::test::requireSharedData("7scenes_redkitchen_tsdf_fusion_python");
  const auto truth_source = io::openDataset(kRedKitchen);
  const fs::path log = fs::temp_directory_path() / "vdbmap_test_drift_modes";
  fs::remove_all(log);
  sim::LogDriftConfig drift;
  drift.seed = 7;
  drift.sigma_translation_m = 0.006;
  drift.sigma_yaw_deg = 0.2;
  const sim::DriftedLog drifted = sim::writeDriftedLog(*truth_source, log, drift);
  INFO("correction at frame " << drifted.event_frame << ", drift there " << drifted.drift_at_event_m << " m, "
                              << drifted.drift_at_event_deg << " deg");
  // The drift must be large against the voxel, or the test shows nothing.
  REQUIRE(drifted.drift_at_event_m > 2 * kVoxel_m);
  const auto drifted_source = io::openDataset(log);
  REQUIRE(drifted_source->corrections().size() == 1);

  ReplayConfig replay;
  replay.frame_stride = kStride;

  // The reference: the same frames at their true poses.
  Mapper truth(configFor(ConsistencyMode::None, truth_source->sensor()));
  replayLog(*truth_source, truth, replay);
  const TriangleMesh truth_mesh = extractMesh(truth.volume());
  REQUIRE(truth_mesh.vertices.size() > 10000);

  EvalConfig eval;
  eval.completeness_threshold_m = 2 * kVoxel_m;
  std::map<ConsistencyMode, ModeRun> runs;
  for (const ConsistencyMode mode :
       {ConsistencyMode::None, ConsistencyMode::Submap, ConsistencyMode::All, ConsistencyMode::Keyframes}) {
    Mapper mapper(configFor(mode, drifted_source->sensor()));
    const ReplayResult r = replayLog(*drifted_source, mapper, replay);
    ModeRun& run = runs[mode];
    run.eval = evaluateSurface(extractMesh(mapper.volume()), truth_mesh, eval);
    run.kept = mapper.keyframesKept();
    run.correction_events = r.correction_events;
    UNSCOPED_INFO(toString(mode) << ": rmse " << run.eval.accuracy_rmse_m << " m, completeness "
                                 << run.eval.completeness << ", keyframes kept " << run.kept);
  }
  const ModeRun& none = runs[ConsistencyMode::None];
  const ModeRun& all = runs[ConsistencyMode::All];
  const ModeRun& keyframes = runs[ConsistencyMode::Keyframes];

  // The true-pose map has RMSE 0 and completeness 1 against itself; "within 10 %" of it means at
  // least 90 % of its surface is reproduced within 2 voxels, and the surface found lies within
  // half a voxel RMS of it.
  for (const ModeRun* run : {&all, &keyframes}) {
    CHECK(run->correction_events == 1);
    CHECK(run->eval.completeness >= 0.9);
    CHECK(run->eval.accuracy_rmse_m <= 0.5 * kVoxel_m);
  }
  // Without correction the drifted half of the sequence lands in the wrong place.
  CHECK(none.eval.accuracy_rmse_m >= 2.0 * keyframes.eval.accuracy_rmse_m);
  CHECK(none.eval.completeness <= keyframes.eval.completeness - 0.05);
  // Pruning keeps fewer frames than keeping all of them.
  CHECK(all.kept == truth_source->size() / kStride);
  CHECK(keyframes.kept < all.kept);
  fs::remove_all(log);
}
