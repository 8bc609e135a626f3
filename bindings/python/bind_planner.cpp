// The exploration planner's parameters as `vdbmap.planner`: what vdbmap.sim.ExplorationConfig.planner
// holds (frontiers, viewpoints, costs, paths, tour, refinement, trajectories), its counters and
// statuses. The planner itself runs inside vdbmap.sim's exploration.
#include "binding.hpp"

#include "vdbmap/planner/exploration_manager.hpp"

namespace vdbmap::python {
namespace {

using namespace vdbmap::planner;

void bindFrontierAndViewpoints(py::module_& m) {
  py::class_<FrontierConfig> f(m, "FrontierConfig",
                               "Frontier clusters (FUEL's cluster_min, cluster_size_xy, down_sample).");
  addStructProtocol(f);
  f.def_readwrite("min_cluster_size", &FrontierConfig::min_cluster_size,
                  "smaller 26-connected components are dropped; [1, 1e8]")
      .def_readwrite("split_radius_xy_m", &FrontierConfig::split_radius_xy_m,
                     "a cluster reaching farther than this from its centroid in x-y is split; (0, 1e4]")
      .def_readwrite("sample_stride_vox", &FrontierConfig::sample_stride_vox,
                     "one representative voxel per cube of this many voxels a side; [1, 64]")
      .def("validate", &FrontierConfig::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<CameraFrustum> c(m, "CameraFrustum", "The camera the planner scores viewpoints with.");
  addStructProtocol(c);
  c.def_readwrite("tan_half_fov_x", &CameraFrustum::tan_half_fov_x, "half image width / fx; (0, 100]")
      .def_readwrite("tan_half_fov_y", &CameraFrustum::tan_half_fov_y, "half image height / fy; (0, 100]")
      .def_readwrite("min_range_m", &CameraFrustum::min_range_m, "[0, max_range_m)")
      .def_readwrite("max_range_m", &CameraFrustum::max_range_m, "(min_range_m, 1e3]")
      .def("validate", &CameraFrustum::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<ViewpointFallback> fb(m, "ViewpointFallback",
                                   "The second, closer and taller ring search for clusters with no ring viewpoint.");
  addStructProtocol(fb);
  fb.def_readwrite("enabled", &ViewpointFallback::enabled, "search again when the rings find no viewpoint")
      .def_readwrite("ring_radius_min_m", &ViewpointFallback::ring_radius_min_m, "(0, ring_radius_max_m]")
      .def_readwrite("ring_radius_max_m", &ViewpointFallback::ring_radius_max_m, "[ring_radius_min_m, 100]")
      .def_readwrite("ring_count", &ViewpointFallback::ring_count, "radii evenly spaced from min to max; [1, 100]")
      .def_readwrite("height_offsets_m", &ViewpointFallback::height_offsets_m,
                     "list of ring heights relative to the centroid (assign a new list to change it)")
      .def_readwrite("min_clearance_m", &ViewpointFallback::min_clearance_m,
                     "every voxel within this distance of a fallback viewpoint is known-free; [0, 10]")
      .def_readwrite("min_visible_fraction", &ViewpointFallback::min_visible_fraction,
                     "a viewpoint passes seeing more than min_visible_samples or at least this fraction of the "
                     "cluster's samples; (0, 1]")
      .def("validate", &ViewpointFallback::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<ViewpointConfig> v(m, "ViewpointConfig", "Viewpoints sampled on rings around each cluster.");
  addStructProtocol(v);
  v.def_readwrite("ring_radius_min_m", &ViewpointConfig::ring_radius_min_m,
                  "FUEL candidate_rmin; (0, ring_radius_max_m]")
      .def_readwrite("ring_radius_max_m", &ViewpointConfig::ring_radius_max_m,
                     "FUEL candidate_rmax; [ring_radius_min_m, 100]")
      .def_readwrite("ring_count", &ViewpointConfig::ring_count, "radii evenly spaced from min to max; [1, 100]")
      .def_readwrite("angle_step_deg", &ViewpointConfig::angle_step_deg, "FUEL candidate_dphi; (0, 180]")
      .def_readwrite("height_offsets_m", &ViewpointConfig::height_offsets_m,
                     "list of ring heights relative to the centroid (assign a new list to change it)")
      .def_readwrite("min_clearance_m", &ViewpointConfig::min_clearance_m,
                     "every voxel within this distance of a viewpoint is known-free; [0, 10]")
      .def_readwrite("min_visible_samples", &ViewpointConfig::min_visible_samples,
                     "FUEL min_visib_num: a viewpoint must see more cluster samples than this; [0, 1e6]")
      .def_readwrite("look_into_unknown", &ViewpointConfig::look_into_unknown,
                     "a sample counts as seen when the camera looks into an unknown neighbour of it (True), "
                     "or, as FUEL, when it sees the sample's free voxel (False)")
      .def_readwrite("unknown_entry_reach_vox", &ViewpointConfig::unknown_entry_reach_vox,
                     "with look_into_unknown: how far (voxels) from the neighbour the ray may enter unknown space; "
                     "[0, 100]")
      .def_readwrite("voxel_rule_fallback", &ViewpointConfig::voxel_rule_fallback,
                     "with look_into_unknown: a cluster no candidate observes that way gets viewpoints by FUEL's rule")
      .def_readwrite("vertical_into_unknown", &ViewpointConfig::vertical_into_unknown,
                     "with FUEL's rule: a sample whose unknown neighbours lie only above or below it counts only when "
                     "the camera looks into them (the exploration manager keeps it until no target is left)")
      .def_readwrite("camera", &ViewpointConfig::camera, "CameraFrustum")
      .def_readwrite("fallback", &ViewpointConfig::fallback, "ViewpointFallback")
      .def("validate", &ViewpointConfig::validate, "Raises ValueError naming the field and its allowed range.");
}

void bindCostsAndPaths(py::module_& m) {
  py::class_<CostConfig> c(m, "CostConfig",
                           "Cost between viewpoints: max(path / v_max, yaw / yaw_rate) + direction term.");
  addStructProtocol(c);
  c.def_readwrite("v_max_m_s", &CostConfig::v_max_m_s, "(0, 100]")
      .def_readwrite("yaw_rate_max_rad_s", &CostConfig::yaw_rate_max_rad_s, "(0, 100]")
      .def_readwrite("w_dir", &CostConfig::w_dir, "FUEL's w_dir, seconds per radian; [0, 1e3]")
      .def_readwrite("unreachable_cost_s", &CostConfig::unreachable_cost_s, "cost of a pair without a path; (0, 1e9]")
      .def("validate", &CostConfig::validate, "Raises ValueError naming the field and its allowed range.");

  py::enum_<PathSearch>(m, "PathSearch", "How a path is searched when the straight segment is blocked.")
      .value("Sampling", PathSearch::Sampling, "OMPL's RRTConnect and simplifier")
      .value("Grid", PathSearch::Grid, "A* on a lattice of voxel centres, complete at its resolution")
      .value("SamplingThenGrid", PathSearch::SamplingThenGrid, "RRTConnect; the lattice where it finds nothing");

  py::class_<PathConfig> p(
      m, "PathConfig", "Collision-free paths in the map (straight line, else OMPL RRTConnect or a lattice search).");
  addStructProtocol(p);
  p.def_readwrite("clearance_m", &PathConfig::clearance_m, "known-free distance around the path; [0, 5]")
      .def_readwrite("check_step_m", &PathConfig::check_step_m, "OMPL's validity-check resolution; 0 = half a voxel")
      .def_readwrite("time_limit_s", &PathConfig::time_limit_s, "wall-clock budget of one search; (0, 60]")
      .def_readwrite("max_iterations", &PathConfig::max_iterations,
                     "RRTConnect iterations of one search; 0 = only the time limit; [0, 1e9]")
      .def_readwrite("rrt_range_m", &PathConfig::rrt_range_m, "RRTConnect's extension length; 0 = OMPL's default")
      .def_readwrite("simplify_rounds", &PathConfig::simplify_rounds, "shortcutting rounds; [0, 100]")
      .def_readwrite("seed", &PathConfig::seed, "OMPL's seed")
      .def_readwrite("search", &PathConfig::search, "PathSearch: how a blocked straight segment is searched around")
      .def("validate", &PathConfig::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<TourConfig> t(m, "TourConfig", "The global tour's ATSP solver.");
  addStructProtocol(t);
  t.def_readwrite("time_limit_s", &TourConfig::time_limit_s, "solver budget; (0, 60]")
      .def_readwrite("seed", &TourConfig::seed, "solver seed")
      .def_readwrite("max_iterations", &TourConfig::max_iterations, "solver rounds; 0 = only the time limit")
      .def_readwrite("max_stale_iterations", &TourConfig::max_stale_iterations,
                     "rounds in a row without a shorter tour after which the solver stops; 0 = never")
      .def_readwrite("max_planned_pairs", &TourConfig::max_planned_pairs,
                     "pairs of targets planned per tour at most, the rest estimated by the straight leg; 0 = all")
      .def("validate", &TourConfig::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<RefinementConfig> r(m, "RefinementConfig", "Local viewpoint refinement (FUEL's refined_*).");
  addStructProtocol(r);
  r.def_readwrite("max_clusters", &RefinementConfig::max_clusters, "clusters of the tour refined; [1, 100]")
      .def_readwrite("radius_m", &RefinementConfig::radius_m, "refine no farther than this (after two); (0, 1e4]")
      .def_readwrite("top_viewpoints", &RefinementConfig::top_viewpoints, "viewpoints per layer; [1, 1000]")
      .def_readwrite("max_planned_edges", &RefinementConfig::max_planned_edges,
                     "edges the lazy search plans at most, the rest at their straight-leg bound; 0 = all it needs")
      .def_readwrite("max_decay", &RefinementConfig::max_decay,
                     "keep viewpoints seeing this share of the best's; [0, 1]")
      .def_readwrite("min_distance_m", &RefinementConfig::min_distance_m, "skip viewpoints this close; [0, 1e3]")
      .def("validate", &RefinementConfig::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<TrajectoryConfig> j(m, "TrajectoryConfig", "Minimum-time trajectories along paths.");
  addStructProtocol(j);
  j.def_readwrite("v_max_m_s", &TrajectoryConfig::v_max_m_s, "(0, 100]")
      .def_readwrite("a_max_m_s2", &TrajectoryConfig::a_max_m_s2, "(0, 100]")
      .def_readwrite("yaw_rate_max_rad_s", &TrajectoryConfig::yaw_rate_max_rad_s, "(0, 100]")
      .def_readwrite("yaw_acc_max_rad_s2", &TrajectoryConfig::yaw_acc_max_rad_s2, "(0, 1000]")
      .def_readwrite("normal_acc_share", &TrajectoryConfig::normal_acc_share, "share of a_max for turning; (0, 1)")
      .def_readwrite("corner_fraction", &TrajectoryConfig::corner_fraction, "arc start before a corner; (0, 0.5]")
      .def_readwrite("ds_m", &TrajectoryConfig::ds_m, "speed profile spacing; (0, 1]")
      .def_readwrite("clearance_m", &TrajectoryConfig::clearance_m, "clearance of arcs and lead-ins; [0, 5]")
      .def_readwrite("check_step_m", &TrajectoryConfig::check_step_m, "0 = half a voxel; [0, 1]")
      .def_readwrite("corner_shrink_steps", &TrajectoryConfig::corner_shrink_steps, "arc halvings; [0, 30]")
      .def_readwrite("yaw_along_travel", &TrajectoryConfig::yaw_along_travel,
                     "face the direction of travel while moving, turning to the goal yaw at the end")
      .def_readwrite("yaw_lead_s", &TrajectoryConfig::yaw_lead_s,
                     "with yaw_along_travel, face the point this much later on the trajectory; (0, 10]")
      .def_readwrite("start_facing_rad", &TrajectoryConfig::start_facing_rad,
                     "with yaw_along_travel: face the way within this of the yaw before leaving free_way_m; [0, pi]")
      .def_readwrite("free_way_m", &TrajectoryConfig::free_way_m,
                     "with yaw_along_travel: the way from the start that needs no facing; the stopping point stays "
                     "within it until the vehicle faces the way; >= 0")
      .def_readwrite("lead_in_at_speed", &TrajectoryConfig::lead_in_at_speed,
                     "a moving start turns onto a path across its velocity on an arc from the vehicle at its "
                     "speed where that arc is clear (off: straight lead-ins that brake into a tighter turn)")
      .def("validate", &TrajectoryConfig::validate, "Raises ValueError naming the field and its allowed range.");
}

void bindAlcParams(py::module_& m) {
  py::class_<AlcConfig> a(m, "AlcConfig",
                          "Active loop closure (docs/planner.md); the history and cluster parameters stay at their C++ "
                          "defaults.");
  addStructProtocol(a);
  a.def_readwrite("epsilon", &AlcConfig::epsilon, "detour iff C_loop <= (1 + epsilon) C_frt; [0, 100]")
      .def_readwrite("search_radius_m", &AlcConfig::search_radius_m, "candidate clusters have a viewpoint this close")
      .def_readwrite("initial_period_s", &AlcConfig::initial_period_s, "no ALC in the first seconds of a flight")
      .def_readwrite("give_up_timeout_s", &AlcConfig::give_up_timeout_s, "a detour without a loop closure ends then")
      .def_readwrite("suspension_s", &AlcConfig::suspension_s, "ALC is off this long after giving up")
      .def_readwrite("loop_quiet_s", &AlcConfig::loop_quiet_s, "ALC is off this long after any loop closure")
      .def_readwrite("max_failures_per_cluster", &AlcConfig::max_failures_per_cluster,
                     "given up this often, a cluster is never chosen again")
      .def_readwrite("finish_loop_age_s", &AlcConfig::finish_loop_age_s,
                     "before finishing, a detour to close a loop when the last is this old; 0: none")
      .def_readwrite("finish_search_radius_m", &AlcConfig::finish_search_radius_m,
                     "the detour before finishing goes to a cluster with a viewpoint this close")
      .def_readwrite("max_finish_detours", &AlcConfig::max_finish_detours, "detours before finishing per flight")
      .def_readwrite("unreachable_cost_s", &AlcConfig::unreachable_cost_s,
                     "legs at or above this are left out of both sums")
      .def_readwrite("tour", &AlcConfig::tour, "TourConfig of both tours")
      .def("validate", &AlcConfig::validate, "Raises ValueError naming the field and its allowed range.");
}

void bindExplorationParams(py::module_& m) {
  py::class_<EscapeConfig> esc(m, "EscapeConfig",
                               "Retreats and straight escapes out of a blocked start (bounds, clearance and trajectory "
                               "are set by the exploration manager).");
  addStructProtocol(esc);
  esc.def_readwrite("flown_positions_kept", &EscapeConfig::flown_positions_kept,
                    "flown positions kept for retreats (one voxel apart); [1, 1e6]")
      .def_readwrite("retreat_reach_m", &EscapeConfig::retreat_reach_m,
                     "how far back along the way flown a retreat goes; [0, 100]")
      .def_readwrite("escape_reach_m", &EscapeConfig::escape_reach_m,
                     "how far a straight escape looks for a clear point; (0, 10]")
      .def("validate", &EscapeConfig::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<RecentFramesConfig> rf(m, "RecentFramesConfig",
                                    "The safety layer's recent depth frames (max_range_m and free_margin_m are set by "
                                    "the exploration manager).");
  addStructProtocol(rf);
  rf.def_readwrite("window_s", &RecentFramesConfig::window_s, "frames older than this are forgotten; (0, 600]")
      .def_readwrite("dense_s", &RecentFramesConfig::dense_s,
                     "frames this recent are all kept, older ones one per sparse_period_s; (0, 600]")
      .def_readwrite("sparse_period_s", &RecentFramesConfig::sparse_period_s,
                     "spacing of the frames kept older than dense_s; [0, 60]")
      .def_readwrite("pool_px", &RecentFramesConfig::pool_px, "side of the pixel blocks depth is pooled over; [1, 64]")
      .def_readwrite("max_range_m", &RecentFramesConfig::max_range_m, "trusted range; (0, 1000]")
      .def_readwrite("free_margin_m", &RecentFramesConfig::free_margin_m,
                     "seen free: the surface behind lies at least this much farther; [0, 10]")
      .def_readwrite("newer_free_clears", &RecentFramesConfig::newer_free_clears,
                     "a surface voxel that a newer frame saw free, centre and corners, is no longer a surface")
      .def("validate", &RecentFramesConfig::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<OdometryDrift> od(m, "OdometryDrift",
                               "What the odometry is expected to drift (a VIO's noise spec): random walks and "
                               "biases in position per axis and in yaw.");
  addStructProtocol(od);
  od.def_readwrite("position_m_per_sqrt_s", &OdometryDrift::position_m_per_sqrt_s,
                   "position random walk per axis (one sigma after 1 s); [0, 10]")
      .def_readwrite("position_bias_m_per_s", &OdometryDrift::position_bias_m_per_s,
                     "velocity bias per axis; [-10, 10]")
      .def_readwrite("yaw_rad_per_sqrt_s", &OdometryDrift::yaw_rad_per_sqrt_s,
                     "yaw random walk (one sigma after 1 s); [0, 10]")
      .def_readwrite("yaw_bias_rad_per_s", &OdometryDrift::yaw_bias_rad_per_s, "yaw-rate bias; [-1, 1]")
      .def(
          "displacement_m",
          [](const OdometryDrift& d, double t_s, double lever_m, double path_m) {
            return d.displacement_m(t_s, lever_m, path_m);
          },
          py::arg("t_s"), py::arg("lever_m"), py::arg("path_m") = 0.0,
          "expected displacement after t_s of a point lever_m from the camera, the vehicle flying path_m meanwhile")
      .def("axis_displacement_m", &OdometryDrift::axisDisplacement_m, py::arg("t_s"),
           "expected position error along one axis (one sigma, e.g. vertical) after t_s")
      .def("longest_within", &OdometryDrift::longestWithin, py::arg("tolerance_m"), py::arg("lever_m"),
           py::arg("min_s"), py::arg("max_s"),
           "the longest time in [min_s, max_s] whose displacement stays within tolerance_m")
      .def("validate", &OdometryDrift::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<SafetyConfig> sc(m, "SafetyConfig",
                              "The drift-free safety layer near the vehicle: recent depth frames as obstacles, "
                              "emergency stops, looking along the way before flying it.");
  addStructProtocol(sc);
  sc.def_readwrite("enabled", &SafetyConfig::enabled, "the layer is on (off by default)")
      .def_readwrite("face_travel", &SafetyConfig::face_travel,
                     "trajectories face the direction of travel while moving")
      .def_readwrite("recent", &SafetyConfig::recent, "RecentFramesConfig")
      .def_readwrite("odometry", &SafetyConfig::odometry,
                     "OdometryDrift or None (unknown): with it the recent frames are trusted for as long as its "
                     "drift allows, up to max_window_s (assign a whole OdometryDrift: reading gives a copy)")
      .def_readwrite("max_window_s", &SafetyConfig::max_window_s,
                     "the longest the odometry's drift may widen recent.window_s to; (0, 600]")
      .def_readwrite("drift_tolerance_m", &SafetyConfig::drift_tolerance_m,
                     "the drift a recent frame may carry at drift_lever_m from the camera; [0, 10]")
      .def_readwrite("drift_lever_m", &SafetyConfig::drift_lever_m, "[0, 100]")
      .def("window_s", &SafetyConfig::window_s, "how long the recent frames are trusted")
      .def("seen_age_s", &SafetyConfig::seenAge_s,
           "how old, when the vehicle gets to a point of its way, a frame may be and still count as having seen it")
      .def_readwrite("clearance_m", &SafetyConfig::clearance_m,
                     "the rest of the trajectory keeps this from recent surface voxels; [0, 5]")
      .def_readwrite("look_margin_m", &SafetyConfig::look_margin_m,
                     "the way ahead seen free: braking distance plus this; [0, 10]")
      .def_readwrite("look_side_m", &SafetyConfig::look_side_m,
                     "how far to the left and right of the way ahead must have been seen too; 0: its middle only; "
                     "[0, 5]")
      .def_readwrite("look_steep", &SafetyConfig::look_steep,
                     "a point of the way ahead above or below the camera's view is checked at the steepest point of "
                     "its vertical line in view (default True), else exempt")
      .def_readwrite("seen_until_arrival", &SafetyConfig::seen_until_arrival,
                     "a point of a way counts as seen only by frames at most seen_age_s() old when the vehicle gets "
                     "there (default True), else by any frame in the recent window")
      .def_readwrite("path_drift", &SafetyConfig::path_drift,
                     "where a frame's drift at arrival also counts the path flown since it (default Off: its age "
                     "alone)")
      .def_readwrite(
          "near_drift_tolerance_m", &SafetyConfig::near_drift_tolerance_m,
          "with seen_until_arrival and a declared odometry, near a recent surface a frame counts only "
          "while its drift at arrival stays within this (near_seen_age_s()); 0 (the default): off, else below "
          "drift_tolerance_m")
      .def("near_seen_age_s", &SafetyConfig::nearSeenAge_s,
           "how old a frame may be when the vehicle passes near a recent surface and still count as having seen "
           "the way there")
      .def_readwrite("max_chained_looks", &SafetyConfig::max_chained_looks,
                     "looks in a row that leave the way unseen before the target gets a failure; [1, 100]")
      .def_readwrite("seen_free_is_free", &SafetyConfig::seen_free_is_free,
                     "paths also read free what the recent frames saw free, whatever the global map says (default "
                     "True)")
      .def_readwrite("map_thin_obstacles", &SafetyConfig::map_thin_obstacles,
                     "True: paths read the global map's thin structure as obstacles; False (the default) leaves it "
                     "to the recent surfaces, but see map_thin_without_drift")
      .def_readwrite("map_thin_without_drift", &SafetyConfig::map_thin_without_drift,
                     "True (the default): paths read the global map's thin structure also when the declared "
                     "odometry does not drift at all (s1), where a surface seen again leaves no ghost")
      .def("effective_map_thin_obstacles", &SafetyConfig::mapThinObstacles,
           "whether paths read the global map's thin structure: map_thin_obstacles, or map_thin_without_drift with "
           "a declared odometry that does not drift")
      .def_readwrite("vertical_margin_m", &SafetyConfig::vertical_margin_m,
                     "paths keep this much more from the global map's surfaces straight above and below, when the "
                     "odometry may drift (the camera sees neither); [0, 2]")
      .def_readwrite("vertical_margin_sigmas", &SafetyConfig::vertical_margin_sigmas,
                     "with a declared odometry the margin grows to this many sigmas of its vertical drift over "
                     "the map's age; [0, 10]")
      .def_readwrite("max_vertical_margin_m", &SafetyConfig::max_vertical_margin_m,
                     "the most the margin grows to (never below vertical_margin_m); [0, 2]")
      .def("effective_vertical_margin_m", &SafetyConfig::verticalMargin_m, py::arg("map_age_s") = 0.0,
           "the margin kept while the map's oldest frame is map_age_s old: 0 when the declared odometry does not "
           "drift, vertical_margin_m without a declared odometry, else grown with its vertical drift")
      .def("validate", &SafetyConfig::validate, "Raises ValueError naming the field and its allowed range.");

  py::enum_<PathDriftScope>(m, "PathDriftScope",
                            "Where the safety layer counts the path flown since a frame in its drift.")
      .value("Off", PathDriftScope::Off, "nowhere: a frame's age alone")
      .value("NearSurfaces", PathDriftScope::NearSurfaces, "where the way passes near a recent surface")
      .value("Everywhere", PathDriftScope::Everywhere, "at every point of the way checked");
  py::enum_<FinalSweepScope>(m, "FinalSweepScope", "Which small clusters the final sweep visits.")
      .value("All", FinalSweepScope::All,
             "every small cluster, also those appearing during the sweep, until covered or blacklisted")
      .value("Pockets", FinalSweepScope::Pockets,
             "the pockets left when the sweep began, and what remains of them, until covered or blacklisted")
      .value("PocketsOnce", FinalSweepScope::PocketsOnce, "each such pocket until one visit of it is over");

  py::class_<ExplorationManagerConfig> e(m, "ExplorationManagerConfig",
                                  "The exploration manager (FUEL-style). box_W is required; the pieces' bounds are "
                                  "set from it. Nested structs are edited in place.");
  addStructProtocol(e);
  e.def_property(
       "box_W", [](const ExplorationManagerConfig& self) { return toArrays(self.box_W); },
       [](ExplorationManagerConfig& self, py::handle value) { self.box_W = toBox(value, "box_W"); },
       "the exploration box (min (3,), max (3,)) in the world frame, or None (unset)")
      .def_readwrite("frontier", &ExplorationManagerConfig::frontier, "FrontierConfig")
      .def_readwrite("viewpoint", &ExplorationManagerConfig::viewpoint, "ViewpointConfig")
      .def_readwrite("cost", &ExplorationManagerConfig::cost, "CostConfig")
      .def_readwrite("path", &ExplorationManagerConfig::path,
                     "PathConfig of the flown paths (0.1 s OMPL budget, the lattice where RRTConnect finds nothing)")
      .def_readwrite("cost_path", &ExplorationManagerConfig::cost_path, "PathConfig of paths only measured (0.01 s)")
      .def_readwrite("tour", &ExplorationManagerConfig::tour, "TourConfig")
      .def_readwrite("refinement", &ExplorationManagerConfig::refinement, "RefinementConfig")
      .def_readwrite("trajectory", &ExplorationManagerConfig::trajectory, "TrajectoryConfig")
      .def_property(
          "start_free_half_size_m",
          [](const ExplorationManagerConfig& self) { return toArray(self.start_free_half_size_m); },
          [](ExplorationManagerConfig& self, py::handle v) {
            self.start_free_half_size_m = toVec3(v, "start_free_half_size_m");
          },
          "(3,) half-sizes of the box around the start where unknown reads free; each [0, 10]")
      .def_readwrite("initial_turn", &ExplorationManagerConfig::initial_turn, "turn once on the spot before exploring")
      .def_readwrite("viewpoint_margin_z_m", &ExplorationManagerConfig::viewpoint_margin_z_m,
                     "viewpoints keep this far from the box's bottom and top; [0, 10]")
      .def_readwrite("alc_enabled", &ExplorationManagerConfig::alc_enabled, "active loop closure (off: plain FUEL)")
      .def_readwrite("alc", &ExplorationManagerConfig::alc, "AlcConfig")
      .def_readwrite("safety", &ExplorationManagerConfig::safety, "SafetyConfig")
      .def_readwrite("replan_time_left_s", &ExplorationManagerConfig::replan_time_left_s,
                     "replan when less trajectory is left (FUEL thresh_replan1); [0, 100]")
      .def_readwrite("replan_covered_after_s", &ExplorationManagerConfig::replan_covered_after_s,
                     "replan when the target is covered after this long (thresh_replan2); [0, 100]")
      .def_readwrite("replan_period_s", &ExplorationManagerConfig::replan_period_s,
                     "replan at least this often; (0, 1000]")
      .def_readwrite("covered_fraction", &ExplorationManagerConfig::covered_fraction,
                     "a target is covered when this share of its frontier is gone; (0, 1]")
      .def_readwrite("collision_radius_m", &ExplorationManagerConfig::collision_radius_m,
                     "known-free space kept around the rest of the trajectory; [0, path.clearance_m]")
      .def_readwrite("max_failures", &ExplorationManagerConfig::max_failures, "failures before a target is blacklisted")
      .def_readwrite("all_failed_spacing_s", &ExplorationManagerConfig::all_failed_spacing_s,
                     "when every target tried fails from a clear start, their failures count only this long after "
                     "the last such replan whose failures counted; [0, 60]")
      .def_readwrite("revisit_rounds", &ExplorationManagerConfig::revisit_rounds,
                     "times per run that blacklisted clusters get one more try and viewpoints are recomputed when "
                     "only blacklisted clusters or clusters without a viewpoint are left; [0, 100]")
      .def_readwrite("final_min_cluster_size", &ExplorationManagerConfig::final_min_cluster_size,
                     "when no target is left, the frontier's min cluster size drops to this once, for a final "
                     "sweep of the small clusters (0: off); [0, 1e8]")
      .def_readwrite("late_large_min_visible_samples", &ExplorationManagerConfig::late_large_min_visible_samples,
                     "from the first time no target is left, large clusters take this fallback threshold when lower, "
                     "and those still without a viewpoint are looked at again (15 or more: off); [0, 1e6]")
      .def_readwrite("final_sweep", &ExplorationManagerConfig::final_sweep,
                     "which small clusters the final sweep visits (FinalSweepScope)")
      .def_readwrite("max_targets_per_replan", &ExplorationManagerConfig::max_targets_per_replan,
                     "targets tried per replan")
      .def_readwrite("keep_target", &ExplorationManagerConfig::keep_target,
                     "periodic and frame-shift replans keep flying to the current target while it is live "
                     "(off: the tour's first target wins every replan, as in FUEL)")
      .def_readwrite("initial_turn_parts", &ExplorationManagerConfig::initial_turn_parts,
                     "parts of the initial turn, each under half a turn; [3, 36]")
      .def_readwrite("risk_check_spacing_vox", &ExplorationManagerConfig::risk_check_spacing_vox,
                     "spacing of the collision-risk check along the trajectory, voxels; (0, 10]")
      .def_readwrite("escape", &ExplorationManagerConfig::escape, "EscapeConfig")
      .def_readwrite("max_chained_escapes", &ExplorationManagerConfig::max_chained_escapes,
                     "straight escapes in a row before giving up; [0, 100]")
      .def_readwrite("max_chained_backtracks", &ExplorationManagerConfig::max_chained_backtracks,
                     "goings back the way flown in a row after every target failed; [0, 100]")
      .def("validate", &ExplorationManagerConfig::validate,
           "Raises ValueError naming the field and its allowed range.");

  py::enum_<ExplorationStatus> status(m, "ExplorationStatus", "What one exploration update decided.");
  status.value("Continue", ExplorationStatus::Continue, "keep following the trajectory")
      .value("Planned", ExplorationStatus::Planned, "a new trajectory starts now")
      .value("NoFrontier", ExplorationStatus::NoFrontier, "no target left; the vehicle finishes its trajectory")
      .value("Failed", ExplorationStatus::Failed, "a replan failed (retried on the next update)")
      .value("Finished", ExplorationStatus::Finished, "no reachable frontier left, vehicle at rest");
  status.attr("__str__") = py::cpp_function([](ExplorationStatus s) { return std::string(toString(s)); },
                                            py::name("__str__"), py::is_method(status), "The name logs use.");

  py::class_<ExplorationCounters> c(m, "ExplorationCounters", "Counters of the exploration manager.");
  c.def_readonly("updates", &ExplorationCounters::updates, "update cycles")
      .def_readonly("replans", &ExplorationCounters::replans, "replans attempted (with the initial turn's parts)")
      .def_readonly("replans_failed", &ExplorationCounters::replans_failed, "replans that failed")
      .def_readonly("collision_risks", &ExplorationCounters::collision_risks, "replans triggered by collision risk")
      .def_readonly("target_failures", &ExplorationCounters::target_failures,
                    "failures counted against targets (all kinds)")
      .def_readonly("visit_failures", &ExplorationCounters::visit_failures,
                    "visits whose viewpoint did not see the target")
      .def_readonly("path_failures", &ExplorationCounters::path_failures,
                    "targets without a path or trajectory at a replan")
      .def_readonly("blacklisted", &ExplorationCounters::blacklisted, "clusters blacklisted at the last replan")
      .def_readonly("holds", &ExplorationCounters::holds, "times the vehicle was stopped by a hold")
      .def_readonly("escapes", &ExplorationCounters::escapes,
                    "moves out of a start blocked by occupied voxels (retreats included)")
      .def_readonly("retreats", &ExplorationCounters::retreats, "escapes back along the way flown")
      .def_readonly("revisit_rounds", &ExplorationCounters::revisit_rounds,
                    "ExplorationManagerConfig.revisit_rounds done")
      .def_readonly("final_sweep_clusters", &ExplorationCounters::final_sweep_clusters,
                    "clusters the final sweep (ExplorationManagerConfig.final_min_cluster_size) added")
      .def_readonly("late_large_clusters", &ExplorationCounters::late_large_clusters,
                    "clusters without a viewpoint looked at again when no target was left: large ones "
                    "(ExplorationManagerConfig.late_large_min_visible_samples), every one with "
                    "ViewpointConfig.vertical_into_unknown")
      .def_readonly("emergency_stops", &ExplorationCounters::emergency_stops,
                    "replans because the recent frames saw the trajectory blocked (SafetyConfig)")
      .def_readonly("look_stops", &ExplorationCounters::look_stops,
                    "brakings to look along a way the recent frames had not seen free (SafetyConfig)")
      .def_readonly("looks_resumed", &ExplorationCounters::looks_resumed,
                    "looks after which the vehicle flew on along the way it was flying (SafetyConfig)")
      .def("__repr__", [](py::handle self) { return reprOfProperties(self); });
}

void bindPlanner(py::module_& parent) {
  py::module_ m = submodule(parent, "planner",
                            "The exploration planner's parameters (vdbmap.sim.ExplorationConfig.planner), its "
                            "counters and statuses.");
  bindFrontierAndViewpoints(m);
  bindCostsAndPaths(m);
  bindAlcParams(m);
  bindExplorationParams(m);
}

const BindRegistration registration(kBindPlanner, "planner", &bindPlanner);

}  // namespace
}  // namespace vdbmap::python
