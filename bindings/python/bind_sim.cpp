// The simulator as `vdbmap.sim`: worlds (triangle meshes with exact rays and distances), the depth
// camera, odometry drift, the simulator's settings, and recording a flight as a log.
#include "binding.hpp"

#include "vdbmap/io/sensor_info.hpp"
#include "vdbmap/camera.hpp"
#include "vdbmap/sim/coverage.hpp"
#include "vdbmap/sim/flight.hpp"

#include <pybind11/functional.h>

#include <functional>
#include <limits>

namespace vdbmap::python {
namespace {

using namespace vdbmap::sim;

/// (N, 4) [x, y, z, yaw] waypoints.
std::vector<FlatPose> toWaypoints(py::handle waypoints, const char* arg) {
  const py::array a = py::module_::import("numpy").attr("asarray")(waypoints, "float64");
  if (a.ndim() != 2 || a.shape(1) != 4 || a.shape(0) == 0)
    throw py::value_error(std::string(arg) +
                          ": expected an (N, 4) array of [x, y, z, yaw] rows with N >= 1, got shape " +
                          std::string(py::str(a.attr("shape"))));
  const auto w = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a).unchecked<2>();
  std::vector<FlatPose> out(std::size_t(w.shape(0)));
  for (py::ssize_t i = 0; i < w.shape(0); ++i) out[std::size_t(i)] = {Vec3d(w(i, 0), w(i, 1), w(i, 2)), w(i, 3)};
  return out;
}

void bindWorld(py::module_& m) {
  py::class_<WorldConfig> c(m, "WorldConfig", "How a mesh becomes a World: ceiling clip and cap, degenerate faces.");
  addStructProtocol(c);
  c.def_readwrite("ceiling_clip_z_m", &WorldConfig::ceiling_clip_z_m,
                  "cut the mesh at this height (world z, metres); inf keeps it all")
      .def_readwrite("cap_ceiling", &WorldConfig::cap_ceiling,
                     "close the world with a flat ceiling at ceiling_clip_z_m (needs a finite clip)")
      .def_readwrite("min_triangle_area_m2", &WorldConfig::min_triangle_area_m2,
                     "faces with a smaller area are dropped as degenerate; [0, 1)")
      .def("validate", &WorldConfig::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<WorldStats> s(m, "WorldStats", "What World construction kept and dropped.");
  s.def_readonly("triangles_in", &WorldStats::triangles_in, "triangles of the input mesh")
      .def_readonly("triangles", &WorldStats::triangles, "triangles kept (after clipping, which may split one)")
      .def_readonly("degenerate_dropped", &WorldStats::degenerate_dropped, "zero area, non-finite or bad indices")
      .def_readonly("clipped_away", &WorldStats::clipped_away, "entirely above the ceiling clip")
      .def_readonly("capped", &WorldStats::capped, "a ceiling cap was added")
      .def_readonly("bvh_nodes", &WorldStats::bvh_nodes, "nodes of the bounding volume hierarchy")
      .def_readonly("bvh_depth", &WorldStats::bvh_depth, "its depth")
      .def("__repr__", [](py::handle self) { return reprOfProperties(self); });

  py::class_<World> w(m, "World",
                      "A ground-truth world: a triangle mesh (metres, z up) with exact ray casts and nearest-surface "
                      "distances. Any mesh works, open or closed.");
  w.def(py::init([](py::handle mesh, const WorldConfig& config) {
          const TriangleMesh tm = toMesh(mesh, "mesh");
          py::gil_scoped_release nogil;
          return World(tm, config);
        }),
        py::arg("mesh"), py::arg("config") = WorldConfig{},
        "From a (vertices (V, 3), triangles (T, 3)) mesh. ValueError when the config is invalid or no usable "
        "triangle is left.")
      .def_static(
          "load",
          [](const std::filesystem::path& path, const WorldConfig& config) {
            py::gil_scoped_release nogil;
            return World::load(path, config);
          },
          py::arg("path"), py::arg("config") = WorldConfig{},
          "Reads a PLY, OBJ or OFF mesh and builds the world. OSError when the file cannot be read.")
      .def_property_readonly(
          "bounds", [](const World& self) { return toArrays(self.bounds()); },
          "(min (3,), max (3,)) float64: the box around the (clipped) mesh")
      .def_property_readonly(
          "mesh", [](const World& self) { return toArrays(self.mesh()); },
          "(vertices float32 (V, 3), triangles int32 (T, 3)): the cleaned, clipped mesh")
      .def_property_readonly("stats", &World::stats, "WorldStats (a copy)")
      .def_property_readonly("config", &World::config, "WorldConfig (a copy)")
      .def(
          "distance",
          [](const World& self, py::handle points, double max_distance_m) {
            const PointCloud p = toPoints(points, "points");
            py::array_t<double> out(py::ssize_t(p.size()));
            double* d = out.mutable_data();
            {
              py::gil_scoped_release nogil;
              for (std::size_t i = 0; i < p.size(); ++i) d[i] = self.distance(p[i].cast<double>(), max_distance_m);
            }
            return out;
          },
          py::arg("points"), py::arg("max_distance_m") = std::numeric_limits<double>::infinity(),
          "Exact distance (N,) float64 from each point (N, 3) to the nearest triangle, capped at max_distance_m "
          "(a small cap makes the search faster).")
      .def(
          "is_clear",
          [](const World& self, py::handle points, double clearance_m) {
            const PointCloud p = toPoints(points, "points");
            py::array_t<bool> out(py::ssize_t(p.size()));
            bool* c = out.mutable_data();
            {
              py::gil_scoped_release nogil;
              for (std::size_t i = 0; i < p.size(); ++i) c[i] = self.isClear(p[i].cast<double>(), clearance_m);
            }
            return out;
          },
          py::arg("points"), py::arg("clearance_m"),
          "(N,) bool: True where no surface is within clearance_m of the point (N, 3).")
      .def(
          "is_segment_clear",
          [](const World& self, py::handle a_W, py::handle b_W, double clearance_m) {
            const Vec3d a = toVec3(a_W, "a_W"), b = toVec3(b_W, "b_W");
            py::gil_scoped_release nogil;
            return self.isSegmentClear(a, b, clearance_m);
          },
          py::arg("a_W"), py::arg("b_W"), py::arg("clearance_m"),
          "True when the segment a-b (3,) keeps clearance_m from every surface (conservative advancement). "
          "ValueError when clearance_m <= 0.")
      .def(
          "raycast",
          [](const World& self, py::handle origins_W, py::handle directions_W, double max_t) {
            const PointCloud o = toPoints(origins_W, "origins_W"), d = toPoints(directions_W, "directions_W");
            if (o.size() != d.size())
              throw py::value_error("directions_W: expected as many rows as origins_W (" + std::to_string(o.size()) +
                                    "), got " + std::to_string(d.size()));
            py::array_t<double> t(py::ssize_t(o.size()));
            py::array_t<std::int32_t> tri(py::ssize_t(o.size()));
            double* tt = t.mutable_data();
            std::int32_t* tr = tri.mutable_data();
            {
              py::gil_scoped_release nogil;
              for (std::size_t i = 0; i < o.size(); ++i) {
                const RayHit hit = self.raycast(o[i].cast<double>(), d[i].cast<double>().normalized(), max_t);
                tt[i] = hit.t;
                tr[i] = hit.triangle;
              }
            }
            return py::make_tuple(t, tri);
          },
          py::arg("origins_W"), py::arg("directions_W"), py::arg("max_t") = std::numeric_limits<double>::infinity(),
          "First hits of rays (N, 3) from origins along directions (normalised here) within max_t: (t float64 "
          "(N,), inf where nothing is hit; triangle int32 (N,), -1 where nothing is hit).")
      .def("__repr__",
           [](const World& self) { return "World(triangles=" + std::to_string(self.stats().triangles) + ")"; });
}

void bindCamera(py::module_& m) {
  py::class_<DepthCameraConfig> c(m, "DepthCameraConfig",
                                  "The simulated depth camera; FUEL's by default: 640x480, fx = fy = 387.229, "
                                  "15 Hz, 0.1-5 m.");
  addStructProtocol(c);
  c.def_readwrite("intrinsics", &DepthCameraConfig::intrinsics, "CameraIntrinsics (OpenCV axes)")
      .def_readwrite("rate_hz", &DepthCameraConfig::rate_hz, "frames per second; (0, 1000]")
      .def_readwrite("min_range_m", &DepthCameraConfig::min_range_m, "closer surfaces read 0; [0, max_range_m)")
      .def_readwrite("max_range_m", &DepthCameraConfig::max_range_m,
                     "the sensor's range, written to sensor.json; (min_range_m, 1000]")
      .def_readwrite("far_clip_m", &DepthCameraConfig::far_clip_m,
                     "surfaces up to this distance are reported (>= max_range_m)")
      .def_readwrite("noise_sigma_m", &DepthCameraConfig::noise_sigma_m, "Gaussian depth noise (0 = exact); [0, 1]")
      .def_readwrite("noise_seed", &DepthCameraConfig::noise_seed, "seed of the noise (per seed, frame and pixel)")
      .def_readwrite("depth_scale_m", &DepthCameraConfig::depth_scale_m,
                     "metres per unit of the PNG files a log stores; (0, 0.1]")
      .def("validate", &DepthCameraConfig::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<DepthCamera> cam(m, "DepthCamera",
                              "Renders a World's depth (distance along the optical axis; 0 = nothing within range) "
                              "from a sensor pose T_W_S, OpenCV axes (x right, y down, z forward).");
  cam.def(py::init<const DepthCameraConfig&>(), py::arg("config") = DepthCameraConfig{},
          "ValueError naming the field when the config is out of range.")
      .def_property_readonly("config", &DepthCamera::config, "DepthCameraConfig (a copy)")
      .def_property_readonly("intrinsics", &DepthCamera::intrinsics, "CameraIntrinsics of the images (a copy)")
      .def_property_readonly("period_s", &DepthCamera::period_s, "1 / rate_hz")
      .def(
          "render",
          [](const DepthCamera& self, const World& world, py::handle T_W_S, std::uint64_t frame) {
            const Pose3d T = toPose(T_W_S, "T_W_S");
            DepthImage d;
            {
              py::gil_scoped_release nogil;
              d = self.render(world, T, frame);
            }
            return toArray(d);
          },
          py::arg("world"), py::arg("T_W_S"), py::arg("frame") = 0,
          "The depth image (H, W) float32 metres seen from T_W_S (4, 4), rasterized; `frame` seeds the noise. "
          "Its intrinsics are `intrinsics`.")
      .def(
          "render_by_raycast",
          [](const DepthCamera& self, const World& world, py::handle T_W_S) {
            const Pose3d T = toPose(T_W_S, "T_W_S");
            DepthImage d;
            {
              py::gil_scoped_release nogil;
              d = self.renderByRaycast(world, T);
            }
            return toArray(d);
          },
          py::arg("world"), py::arg("T_W_S"),
          "The same image without noise by one ray per pixel (slower; the reference for render).")
      .def("sensor_info", &DepthCamera::sensorInfo, "The SensorInfo of a log recorded with this camera.")
      .def("__repr__", [](const DepthCamera& self) {
        const CameraIntrinsics& K = self.intrinsics();
        return "DepthCamera(" + std::to_string(K.width) + "x" + std::to_string(K.height) + ")";
      });

  m.def(
      "looking_pose",
      [](py::handle position_W, double yaw, double pitch) {
        return toArray(lookingPose(toVec3(position_W, "position_W"), yaw, pitch));
      },
      py::arg("position_W"), py::arg("yaw"), py::arg("pitch") = 0.0,
      "A camera pose T_W_S (4, 4) at position_W (3,) whose optical axis points along yaw in the x-y plane (yaw 0 = "
      "world +x), image y down, pitched down by `pitch` radians.");
}

void bindDrift(py::module_& m) {
  py::class_<DriftConfig> d(m, "DriftConfig",
                            "Odometry drift of the paper's Table I: velocity and yaw-rate errors integrated at "
                            "rate_hz (variances, not standard deviations). Zero (level s1) by default.");
  addStructProtocol(d);
  d.def_readwrite("mu_xyz_mps", &DriftConfig::mu_xyz_mps, "mean velocity error per axis; [-10, 10]")
      .def_readwrite("sigma2_xyz_m2ps2", &DriftConfig::sigma2_xyz_m2ps2, "variance of the velocity error; [0, 100]")
      .def_readwrite("mu_yaw_radps", &DriftConfig::mu_yaw_radps, "mean yaw-rate error; [-1, 1]")
      .def_readwrite("sigma2_yaw_rad2ps2", &DriftConfig::sigma2_yaw_rad2ps2, "variance of the yaw-rate error; [0, 100]")
      .def_readwrite("rate_hz", &DriftConfig::rate_hz, "integration rate; [1, 10000]")
      .def_readwrite("seed", &DriftConfig::seed, "seed of the draws")
      .def_static("preset", &DriftConfig::preset, py::arg("level"), py::arg("seed") = 1,
                  "Table I's level 's1'..'s4' with the given seed; ValueError otherwise.")
      .def("is_zero", &DriftConfig::isZero, "True when no error is drawn (s1).")
      .def("validate", &DriftConfig::validate, "Raises ValueError naming the field and its allowed range.");
}

void bindSimulatorConfig(py::module_& m) {
  py::enum_<LoopClosureMode> mode(m, "LoopClosureMode", "What a detected loop closure corrects poses with.");
  mode.value("Off", LoopClosureMode::Off, "never close loops; str() is 'off'")
      .value("PoseGraph", LoopClosureMode::PoseGraph, "4-DOF pose-graph optimization; str() is 'pgo'")
      .value("Perfect", LoopClosureMode::Perfect, "the ground truth; str() is 'perfect'");
  mode.def(py::init([](const std::string& text) { return parseLoopClosureMode(text); }), py::arg("name"),
           "From the name the CLI uses; ValueError lists the accepted names.");
  mode.attr("__str__") = py::cpp_function([](LoopClosureMode v) { return std::string(toString(v)); },
                                          py::name("__str__"), py::is_method(mode), "'off', 'pgo' or 'perfect'");

  py::class_<LoopClosureConfig> l(m, "LoopClosureConfig", "When the simulator detects a loop closure.");
  addStructProtocol(l);
  l.def_readwrite("max_distance_m", &LoopClosureConfig::max_distance_m,
                  "true positions at most this far apart; (0, 100]")
      .def_readwrite("max_yaw_rad", &LoopClosureConfig::max_yaw_rad, "true yaws at most this far apart; (0, pi]")
      .def_readwrite("min_age_s", &LoopClosureConfig::min_age_s, "the older frame at least this much older; [0, 1e6]")
      .def_readwrite("min_interval_s", &LoopClosureConfig::min_interval_s, "at most one loop closure per this time")
      .def_readwrite("min_view_overlap", &LoopClosureConfig::min_view_overlap,
                     "fraction of the frame's surface samples the older camera sees too; [0, 1]")
      .def_readwrite("overlap_pixel_stride", &LoopClosureConfig::overlap_pixel_stride,
                     "every k-th pixel per direction samples the overlap; [1, 1000]")
      .def_readwrite("max_overlap_checks", &LoopClosureConfig::max_overlap_checks,
                     "candidates (nearest first) tested per frame; [1, 1000]")
      .def("validate", &LoopClosureConfig::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<PoseGraphSolveConfig> p(m, "PoseGraphSolveConfig", "The pose-graph solver's stopping rules.");
  addStructProtocol(p);
  p.def_readwrite("max_iterations", &PoseGraphSolveConfig::max_iterations, "[1, 10000]")
      .def_readwrite("function_tolerance", &PoseGraphSolveConfig::function_tolerance, "relative cost change")
      .def("validate", &PoseGraphSolveConfig::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<SimulatorConfig> s(m, "SimulatorConfig",
                                "The simulated vehicle's sensors: camera, drift, loop closure. Nested structs are "
                                "edited in place.");
  addStructProtocol(s);
  s.def_readwrite("camera", &SimulatorConfig::camera, "DepthCameraConfig")
      .def_readwrite("camera_pitch_rad", &SimulatorConfig::camera_pitch_rad,
                     "downward pitch of the camera on the body; [-pi/2, pi/2]")
      .def_readwrite("drift", &SimulatorConfig::drift, "DriftConfig (s1, none, by default)")
      .def_readwrite("loop", &SimulatorConfig::loop, "LoopClosureConfig (detection)");
  defEnumField(s, "loop_closure", &SimulatorConfig::loop_closure, &parseLoopClosureMode,
               "LoopClosureMode (or 'off', 'pgo', 'perfect')");
  s.def_readwrite("loop_sigma_m", &SimulatorConfig::loop_sigma_m, "noise of a loop edge per axis; [0, 1]")
      .def_readwrite("loop_sigma_yaw_rad", &SimulatorConfig::loop_sigma_yaw_rad,
                     "noise of a loop edge in yaw; [0, 0.5]")
      .def_readwrite("odometry_sigma_floor", &SimulatorConfig::odometry_sigma_floor,
                     "floor of the odometry edges' standard deviations; [1e-9, 1]")
      .def_readwrite("solve", &SimulatorConfig::solve, "PoseGraphSolveConfig")
      .def("validate", &SimulatorConfig::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<MotionLimits> ml(m, "MotionLimits", "The vehicle's limits; the paper's: 2 m/s, 2 m/s^2, 0.9 rad/s.");
  addStructProtocol(ml);
  ml.def_readwrite("v_max_mps", &MotionLimits::v_max_mps, "(0, 100]")
      .def_readwrite("a_max_mps2", &MotionLimits::a_max_mps2, "(0, 100]")
      .def_readwrite("yaw_rate_max_radps", &MotionLimits::yaw_rate_max_radps, "(0, 100]")
      .def("validate", &MotionLimits::validate, "Raises ValueError naming the field and its allowed range.");
}

void bindFlight(py::module_& m) {
  py::class_<LoopClosure> l(m, "LoopClosure", "A detected loop closure between two frames.");
  l.def_readonly("old_frame", &LoopClosure::old_frame, "index of the earlier frame")
      .def_readonly("new_frame", &LoopClosure::new_frame, "index of the frame that closed the loop")
      .def_readonly("distance_m", &LoopClosure::distance_m, "true distance between the two")
      .def_readonly("yaw_difference_rad", &LoopClosure::yaw_difference_rad, "true yaw difference")
      .def_readonly("view_overlap", &LoopClosure::view_overlap, "fraction of shared surface samples")
      .def("__repr__", [](py::handle self) { return reprOfProperties(self); });

  py::class_<FlightResult> r(m, "FlightResult", "Statistics of a recorded flight (also in simulation.json).");
  r.def_readonly("frames", &FlightResult::frames, "frames recorded")
      .def_readonly("duration_s", &FlightResult::duration_s, "simulated time")
      .def_readonly("path_length_m", &FlightResult::path_length_m, "length of the true path")
      .def_readonly("loop_closures", &FlightResult::loop_closures, "list of LoopClosure")
      .def_readonly("odometry_error_final_m", &FlightResult::odometry_error_final_m,
                    "raw odometry position error at the last frame")
      .def_readonly("odometry_error_max_m", &FlightResult::odometry_error_max_m, "its maximum")
      .def_readonly("estimate_error_rmse_m", &FlightResult::estimate_error_rmse_m,
                    "position error of the published estimates (frames.csv), RMSE")
      .def_readonly("estimate_error_max_m", &FlightResult::estimate_error_max_m, "its maximum")
      .def_readonly("frame_ms_median", &FlightResult::frame_ms_median, "wall time per frame (render, loop, write)")
      .def_readonly("wall_s", &FlightResult::wall_s, "the whole flight")
      .def("__repr__", [](py::handle self) { return reprOfProperties(self); });

  m.def(
      "simulate_flight",
      [](const World& world, const std::filesystem::path& log_dir, const SimulatorConfig& config, py::handle waypoints,
         const MotionLimits& limits, bool overwrite, const std::string& description,
         std::function<void(std::size_t, std::size_t)> progress) {
        // As `vdbmap simulate`: the given waypoints flown stop and go within the limits, or the
        // world's built-in coverage pattern.
        const bool coverage = waypoints.is_none();
        const std::vector<FlatPose> path = coverage ? std::vector<FlatPose>{} : toWaypoints(waypoints, "waypoints");
        FlightConfig options;
        options.overwrite = overwrite;
        options.description = description;
        options.progress = [progress](std::size_t done, std::size_t total) {
          py::gil_scoped_acquire gil;  // Ctrl-C stops the flight after the current frame
          if (PyErr_CheckSignals() != 0) throw py::error_already_set();
          if (progress) progress(done, total);
        };
        py::gil_scoped_release nogil;
        const SampledTrajectory trajectory =
            coverage ? planCoverage(world, CoverageConfig{}).trajectory : timeParametrize(path, limits);
        return simulateFlight(world, trajectory, config, log_dir, options);
      },
      py::arg("world"), py::arg("log_dir"), py::arg("config") = SimulatorConfig{}, py::arg("waypoints") = py::none(),
      py::arg("limits") = MotionLimits{}, py::arg("overwrite") = false, py::arg("description") = "",
      py::arg("progress") = py::none(),
      "Flies the simulated vehicle and records the flight as a log (depth PNGs, frames.csv with the drifting "
      "pose estimates, corrections/, groundtruth.txt, simulation.json), as `vdbmap simulate` does. waypoints: "
      "(N, 4) [x, y, z, yaw] rows (metres, radians), flown stop and go within `limits`; None flies the world's "
      "built-in coverage pattern. progress: None or a callable(frames_done, "
      "frames_to_do). OSError when log_dir holds a log and overwrite is False.");
}

void bindSim(py::module_& parent) {
  py::module_ m = submodule(parent, "sim",
                            "The simulator: ground-truth worlds from meshes, a depth camera, odometry drift (the "
                            "paper's levels s1-s4), loop closure, flights recorded as logs, and closed-loop "
                            "exploration. Arrays and errors as in vdbmap.");
  bindWorld(m);
  bindCamera(m);
  bindDrift(m);
  bindSimulatorConfig(m);
  bindFlight(m);
}

const BindRegistration registration(kBindSim, "sim", &bindSim);

}  // namespace
}  // namespace vdbmap::python
