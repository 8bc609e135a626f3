// Closed-loop exploration in `vdbmap.sim`: its configuration, `run_exploration` (the result in
// memory, with the final Mapper) and `explore` (the run folder `vdbmap explore` writes).
#include "binding.hpp"

#include "vdbmap/mapper.hpp"
#include "vdbmap/sim/exploration.hpp"

#include <pybind11/functional.h>

#include <functional>
#include <memory>

namespace vdbmap::python {
namespace {

using namespace vdbmap::sim;

/// Sensor poses as TUM rows (N, 8): timestamp, tx, ty, tz, qx, qy, qz, qw.
py::array_t<double> toTumArray(const std::vector<io::StampedPose>& poses) {
  py::array_t<double> out({py::ssize_t(poses.size()), py::ssize_t(8)});
  auto a = out.mutable_unchecked<2>();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const py::ssize_t r = py::ssize_t(i);
    const Vec3d t = poses[i].T_W_S.translation();
    const Eigen::Quaterniond q(poses[i].T_W_S.rotation());
    const double row[8] = {poses[i].timestamp_s, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()};
    for (py::ssize_t c = 0; c < 8; ++c) a(r, c) = row[c];
  }
  return out;
}

/// A progress callback for a run with the GIL released: takes the GIL back per frame, lets Ctrl-C
/// stop the run after the current frame, and calls the user's callable (if any).
std::function<void(const ExplorationProgress&)> progressWithSignals(
    std::function<void(const ExplorationProgress&)> user) {
  return [user = std::move(user)](const ExplorationProgress& p) {
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    if (user) user(p);
  };
}

void bindConfig(py::module_& m) {
  py::enum_<BudgetMode> budgets(m, "BudgetMode", "How the planner's and the mapper's per-cycle budgets are counted.");
  budgets.value("WallClock", BudgetMode::WallClock, "wall-clock limits, as on a robot; str() is 'wall-clock'")
      .value("Counted", BudgetMode::Counted, "iterations and frames: runs repeat exactly; str() is 'counted'");
  budgets.def(py::init([](const std::string& text) { return parseBudgetMode(text); }), py::arg("name"),
              "From the name the CLI uses; ValueError lists the accepted names.");
  budgets.attr("__str__") = py::cpp_function([](BudgetMode v) { return std::string(toString(v)); },
                                             py::name("__str__"), py::is_method(budgets), "'wall-clock' or 'counted'");

  py::class_<ExplorationConfig> c(
      m, "ExplorationConfig",
      "A closed-loop exploration: simulator (camera, drift, loop closure), mapper, planner, "
      "start and time limit. The main knobs are also attributes of their own (drift, seed, "
      "voxel_size_m, mode, box, start); nested structs are edited in place. The box and the "
      "start must be set (for_world gives those `vdbmap explore` picks).");
  addStructProtocol(c);
  c.def_readwrite("simulator", &ExplorationConfig::simulator,
                  "SimulatorConfig; its camera reports surfaces up to 30 m (far_clip_m) so rays carve free space")
      .def_readwrite("mapper", &ExplorationConfig::mapper, "vdbmap.MapperConfig (keyframes mode by default)")
      .def_readwrite("planner", &ExplorationConfig::planner, "vdbmap.planner.ExplorationManagerConfig")
      .def_property(
          "start", [](const ExplorationConfig& self) { return toArray(self.start.position_W); },
          [](ExplorationConfig& self, py::handle p) { self.start.position_W = toVec3(p, "start"); },
          "(3,) start position in the world (true and estimated poses agree there at t = 0)")
      .def_property(
          "start_yaw", [](const ExplorationConfig& self) { return self.start.yaw_rad; },
          [](ExplorationConfig& self, double yaw) { self.start.yaw_rad = yaw; }, "start yaw in radians")
      .def_readwrite("max_time_s", &ExplorationConfig::max_time_s, "simulated time limit; (0, 1e5]")
      .def_readwrite("vehicle_radius_m", &ExplorationConfig::vehicle_radius_m,
                     "a collision: the true position closer than this to a surface; [0, 10]")
      .def_property(
          "box", [](const ExplorationConfig& self) { return toArrays(self.planner.box_W); },
          [](ExplorationConfig& self, py::handle box) { self.planner.box_W = toBox(box, "box"); },
          "planner.box_W: the exploration box (min (3,), max (3,)), or None (unset)")
      .def_property(
          "drift",
          py::cpp_function([](ExplorationConfig& self) -> DriftConfig& { return self.simulator.drift; },
                           py::return_value_policy::reference_internal),
          [](ExplorationConfig& self, py::handle drift) {
            setDrift(self, py::isinstance<py::str>(drift)
                               ? DriftConfig::preset(drift.cast<std::string>(), self.simulator.drift.seed)
                               : drift.cast<DriftConfig>());
          },
          "simulator.drift (edited in place); set a DriftConfig or a level name 's1'..'s4' (keeping the drift's "
          "seed), which also declares it to the safety layer (planner.safety.odometry = odometry_drift_of(drift)) "
          "as `vdbmap explore --drift` does; an edit in place does not")
      .def_property(
          "seed", [](const ExplorationConfig& self) { return self.simulator.drift.seed; },
          [](ExplorationConfig& self, std::uint64_t seed) { setSeed(self, seed); },
          "the drift's seed; setting it also seeds the planner (path, cost_path, tour, alc.tour), as `vdbmap "
          "explore --seed`")
      .def_property(
          "voxel_size_m", [](const ExplorationConfig& self) { return self.mapper.tsdf.voxel_size_m; },
          [](ExplorationConfig& self, double v) { self.mapper.tsdf.voxel_size_m = v; }, "mapper.tsdf.voxel_size_m")
      .def_property(
          "mode", [](const ExplorationConfig& self) { return self.mapper.mode; },
          [](ExplorationConfig& self, py::handle mode) {
            self.mapper.mode = toEnum(mode, &parseConsistencyMode, "mode");
          },
          "mapper.mode: vdbmap.ConsistencyMode (or 'none', 'submap', 'all', 'keyframes')")
      .def_static(
          "for_world",
          [](const World& world, double start_height_m, double start_clearance_m) {
            ExplorationConfig config;
            config.planner.box_W = defaultExplorationBox(world);
            config.start.position_W = defaultStartPosition(world, config.planner.box_W, start_height_m, start_clearance_m);
            return config;
          },
          py::arg("world"), py::arg("start_height_m") = 1.0, py::arg("start_clearance_m") = 0.6,
          "Defaults with the box and start `vdbmap explore` picks: default_exploration_box(world) and "
          "default_start_position there.")
      .def(
          "set_budgets",
          [](ExplorationConfig& self, py::handle mode) { setBudgets(self, toEnum(mode, &parseBudgetMode, "mode")); },
          py::arg("mode"),
          "Sets the planner's and the mapper's per-cycle budgets: BudgetMode.Counted (or 'counted', what "
          "`vdbmap explore` uses: the same config gives the same run) or BudgetMode.WallClock (or 'wall-clock', "
          "the defaults, as on a robot).")
      .def("validate", &ExplorationConfig::validate, "Raises ValueError naming the field and its allowed range.");

  m.def(
      "default_exploration_box", [](const World& world) { return toArrays(defaultExplorationBox(world)); },
      py::arg("world"), "The world's bounding box (after its ceiling clip) as (min (3,), max (3,)).");
  m.def(
      "default_start_position",
      [](const World& world, py::handle box, double start_height_m, double start_clearance_m) {
        return toArray(defaultStartPosition(world, toBox(box, "box"), start_height_m, start_clearance_m));
      },
      py::arg("world"), py::arg("box"), py::arg("start_height_m") = 1.0, py::arg("start_clearance_m") = 0.6,
      "The point nearest the box's centre (x, y) at start_height_m above the box's floor that keeps "
      "start_clearance_m from every surface (0.1 m grid), as (3,). ValueError when there is none.");
}

void bindResult(py::module_& m) {
  py::class_<ExplorationProgress> p(m, "ExplorationProgress", "The run after a frame (what progress callbacks get).");
  p.def_readonly("t_s", &ExplorationProgress::t_s, "simulated time")
      .def_readonly("frames", &ExplorationProgress::frames, "frames so far")
      .def_readonly("clusters", &ExplorationProgress::clusters, "frontier clusters")
      .def_readonly("frontier_voxels", &ExplorationProgress::frontier_voxels, "frontier voxels")
      .def_readonly("replans", &ExplorationProgress::replans, "replans so far")
      .def_readonly("loop_closures", &ExplorationProgress::loop_closures, "loop closures so far")
      .def_readonly("collisions", &ExplorationProgress::collisions, "collision events so far")
      .def_readonly("path_length_m", &ExplorationProgress::path_length_m, "true path so far")
      .def_readonly("status", &ExplorationProgress::status, "vdbmap.planner.ExplorationStatus of the last update")
      .def("__repr__", [](py::handle self) { return reprOfProperties(self); });

  py::class_<ExplorationResult> r(m, "ExplorationResult",
                                  "What run_exploration did, with the final map (the mapper, re-integration drained).");
  r.def_readonly("finished", &ExplorationResult::finished, "the planner finished (False: the time limit ended it)")
      .def_readonly("exploration_time_s", &ExplorationResult::exploration_time_s, "simulated time to the finish")
      .def_readonly("path_length_m", &ExplorationResult::path_length_m, "length of the true path")
      .def_readonly("frames_total", &ExplorationResult::frames_total, "camera frames")
      .def_readonly("loop_closures", &ExplorationResult::loop_closures, "loop-closure corrections")
      .def_readonly("collisions", &ExplorationResult::collisions, "distinct collision events (true pose vs world)")
      .def_readonly("min_clearance_m", &ExplorationResult::min_clearance_m,
                    "smallest true distance to a surface (capped at 2 vehicle radii)")
      .def_property_readonly(
          "planner_ms",
          [](const ExplorationResult& self) {
            return py::array_t<double>(py::ssize_t(self.planner_ms.size()), self.planner_ms.data());
          },
          "(R,) float64 wall time of every update that replanned")
      .def_readonly("planner_ms_median", &ExplorationResult::planner_ms_median, "median of planner_ms")
      .def_readonly("planner_ms_max", &ExplorationResult::planner_ms_max, "maximum of planner_ms")
      .def_readonly("map_update_ms_median", &ExplorationResult::map_update_ms_median,
                    "frontier and viewpoint refresh per frame")
      .def_readonly("update_ms_median", &ExplorationResult::update_ms_median,
                    "the planner's whole work per frame (the safety layer's frame, the update, replans)")
      .def_readonly("update_ms_p99", &ExplorationResult::update_ms_p99, "99th percentile of the same (nearest rank)")
      .def_readonly("update_ms_max", &ExplorationResult::update_ms_max, "maximum of the same")
      .def_readonly("frame_wall_ms_median", &ExplorationResult::frame_wall_ms_median, "everything per frame")
      .def_readonly("planner_counters", &ExplorationResult::planner_counters, "vdbmap.planner.ExplorationCounters")
      .def_readonly("keyframes_kept", &ExplorationResult::keyframes_kept, "keyframes the mapper keeps")
      .def_readonly("reintegrated_frames", &ExplorationResult::reintegrated_frames, "re-integrations done")
      .def_property_readonly(
          "trajectory_true", [](const ExplorationResult& self) { return toTumArray(self.trajectory_true); },
          "(N, 8) float64 TUM rows (t, tx, ty, tz, qx, qy, qz, qw): true sensor poses T_W_S per frame")
      .def_property_readonly(
          "trajectory_estimate", [](const ExplorationResult& self) { return toTumArray(self.trajectory_estimate); },
          "(N, 8) float64 TUM rows: the estimated sensor poses the mapper integrated with")
      .def_readonly("flight", &ExplorationResult::flight, "FlightResult of the recorded log (zeros without a log)")
      .def_property_readonly(
          "mapper", [](ExplorationResult& self) -> Mapper& { return *self.mapper; },
          py::return_value_policy::reference_internal,
          "the final vdbmap.Mapper (kept alive by this result): query it, take its volume(), mesh it")
      .def_readonly("wall_s", &ExplorationResult::wall_s, "wall time of the run")
      .def("__repr__", [](const ExplorationResult& self) {
        return "ExplorationResult(finished=" + std::string(self.finished ? "True" : "False") +
               ", frames_total=" + std::to_string(self.frames_total) +
               ", collisions=" + std::to_string(self.collisions) + ")";
      });
}

void bindRuns(py::module_& m) {
  m.def("odometry_drift_of", &odometryDriftOf, py::arg("drift"),
        "The vdbmap.planner.OdometryDrift a DriftConfig makes (random walks of sqrt(sigma2 / rate_hz) per "
        "sqrt(s)), as `vdbmap explore` declares it to the safety layer (planner.safety.odometry).");
  m.def(
      "run_exploration",
      [](const World& world, const ExplorationConfig& config, std::optional<std::filesystem::path> log_dir,
         bool overwrite, const std::string& description, std::function<void(const ExplorationProgress&)> progress) {
        ExplorationRecordConfig options;
        if (log_dir) options.log_dir = *log_dir;
        options.overwrite = overwrite;
        options.description = description;
        options.progress = progressWithSignals(std::move(progress));
        py::gil_scoped_release nogil;
        return runExploration(world, config, options);
      },
      py::arg("world"), py::arg("config"), py::arg("log_dir") = py::none(), py::arg("overwrite") = false,
      py::arg("description") = "", py::arg("progress") = py::none(),
      "Explores the world in closed loop (simulated vehicle, mapper, planner) and returns an ExplorationResult "
      "with the final mapper. log_dir: also record the flight as a log there. progress: None or a "
      "callable(ExplorationProgress) after every frame. ValueError for an invalid config or a start that is not "
      "clear; OSError when log_dir holds a log and overwrite is False.");
  m.def(
      "explore",
      [](const World& world, const ExplorationConfig& config, const std::filesystem::path& run_dir, bool overwrite,
         const std::string& description, std::function<void(const ExplorationProgress&)> progress,
         std::function<void(const std::string&)> report, double completeness_threshold_vox) {
        ExplorationRunConfig options;
        options.overwrite = overwrite;
        options.description = description;
        options.completeness_threshold_vox = completeness_threshold_vox;
        options.progress = progressWithSignals(std::move(progress));
        if (report)
          options.report = [report](const std::string& line) {
            py::gil_scoped_acquire gil;
            report(line);
          };
        {
          py::gil_scoped_release nogil;
          exploreToFolder(world, config, run_dir, options);
        }
        // The summary as the run folder holds it, so Python sees exactly summary.json's keys.
        const py::object json = py::module_::import("json");
        const py::object text =
            py::module_::import("pathlib").attr("Path")(run_dir / "summary.json").attr("read_text")();
        return json.attr("loads")(text);
      },
      py::arg("world"), py::arg("config"), py::arg("run_dir"), py::arg("overwrite") = false,
      py::arg("description") = "", py::arg("progress") = py::none(), py::arg("report") = py::none(),
      py::arg("completeness_threshold_vox") = ExplorationRunConfig{}.completeness_threshold_vox,
      "Explores the world as `vdbmap explore` does and writes the run folder: log/ (replayable), map.vdb, "
      "mesh.ply, trajectory_true.txt, trajectory_odom.txt (TUM) and summary.json, whose content it returns as a "
      "dict (coverage, collisions, accuracy_rmse_m, completeness, ...). report: None or a callable(str) given a "
      "line per stage after the flight. RuntimeError when run_dir holds a run and overwrite is False.");
}

void bindExplore(py::module_& parent) {
  py::module_ m = parent.attr("sim").cast<py::module_>();
  bindConfig(m);
  bindResult(m);
  bindRuns(m);
}

const BindRegistration registration(kBindExplore, "explore", &bindExplore);

}  // namespace
}  // namespace vdbmap::python
