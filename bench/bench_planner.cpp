// Planner timing on an integrated map: frontier detection (from scratch and incremental),
// viewpoints, and one full replanning step (pair costs, legs from the vehicle, global tour, local
// refinement, path and trajectory to the chosen viewpoint). Prints one JSON line per stage and a
// summary line.
//
// The map: a 20 x 14 x 3 m analytic room with boxes and spheres (as bench_integrate), seen from a
// vehicle at the centre turning once on the spot (12 frames, 640 x 480, 5 m range), then a second
// position for the incremental step.
//
//   cmake --build build --target vdbmap_bench_planner && build/bin/vdbmap_bench_planner [repeats]
#include "vdbmap/camera.hpp"
#include "vdbmap/timing.hpp"
#include "vdbmap/planner/assume_free_map.hpp"
#include "vdbmap/planner/frontier.hpp"
#include "vdbmap/planner/local_refinement.hpp"
#include "vdbmap/planner/tour.hpp"
#include "vdbmap/planner/trajectory.hpp"
#include "vdbmap/planner/tsdf_map_query.hpp"
#include "vdbmap/planner/viewpoint.hpp"
#include "vdbmap/testing/analytic_scene.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdlib>
#include <functional>
#include <iostream>

using namespace vdbmap;
using namespace vdbmap::planner;

namespace {
testing::AnalyticScene benchRoom() {
  testing::AnalyticScene s;
  s.addRoom({-10, -7, 0}, {10, 7, 3})
      .addBox({-6, -4, 0}, {-4, -2, 2})
      .addBox({2, 3, 0}, {5, 4, 1.2})
      .addBox({-1, -6, 0}, {1, -5, 2.5})
      .addSphere({4, -3, 1.2}, 0.9)
      .addSphere({-3, 4, 0.8}, 0.6)
      .addBox({6, -1, 0.7}, {8, 1, 0.8});
  return s;
}

/// Median wall time of `repeats` runs of f, in ms.
double timeMedian(int repeats, const std::function<void()>& f) {
  std::vector<double> ms;
  for (int i = 0; i < repeats; ++i) {
    const Stopwatch watch;
    f();
    ms.push_back(watch.ms());
  }
  std::sort(ms.begin(), ms.end());
  return ms[ms.size() / 2];
}

openvdb::CoordBBox integrateTurn(TsdfVolume& volume, const testing::AnalyticScene& scene, const Vec3d& at, int frames,
                                 FrameId first_id) {
  const CameraIntrinsics K;
  openvdb::CoordBBox touched;
  for (int i = 0; i < frames; ++i) {
    const Pose3d T = vdbmap::lookingPose(at, 2.0 * M_PI * i / frames, 0.0);
    const IntegrationStats s = volume.integrate(first_id + FrameId(i), backProject(scene.renderDepth(K, T, 30.0), K), T);
    touched.expand(s.touched_voxels);
  }
  return touched;
}
}  // namespace

int main(int argc, char** argv) {
  const int repeats = argc > 1 ? std::max(1, std::atoi(argv[1])) : 5;
  const testing::AnalyticScene scene = benchRoom();
  TsdfConfig config;
  config.voxel_size_m = 0.1;
  IntegratorConfig integrator;
  integrator.max_range_m = 5.0;
  TsdfVolume volume(config, integrator);
  const Vec3d start(0.0, 0.0, 1.3);
  integrateTurn(volume, scene, start, 12, 0);

  const TsdfMapQuery tsdf(volume);
  const AssumeFreeMap map(tsdf, {boxAround(start, Vec3d(0.5, 0.5, 0.5))});
  FrontierConfig fp;
  fp.bounds_W = Eigen::AlignedBox3d(Vec3d(-10, -7, 0.2), Vec3d(10, 7, 2.8));

  // Frontiers from scratch.
  FrontierMap frontiers(fp);
  const double rebuild_ms = timeMedian(repeats, [&] { frontiers.rebuild(map); });
  std::cout << nlohmann::json{{"stage", "frontier_rebuild"},
                              {"ms_median", rebuild_ms},
                              {"frontier_voxels", frontiers.frontierVoxelCount()},
                              {"clusters", frontiers.clusters().size()},
                              {"known_bounds_voxels", map.knownBounds().volume()}}
                   .dump()
            << std::endl;

  // Viewpoints of every cluster.
  std::vector<std::vector<Viewpoint>> views;
  const double views_ms = timeMedian(repeats, [&] {
    views.clear();
    for (const FrontierCluster& c : frontiers.clusters()) views.push_back(computeViewpoints(c, map));
  });
  std::size_t with_views = 0;
  for (const auto& v : views) with_views += !v.empty();
  std::cout << nlohmann::json{{"stage", "viewpoints"},
                              {"ms_median", views_ms},
                              {"ms_per_cluster", views_ms / double(std::max<std::size_t>(1, views.size()))},
                              {"clusters_with_viewpoints", with_views}}
                   .dump()
            << std::endl;

  // One full replanning step from the start (the pair table from scratch).
  std::vector<TourTarget> targets;
  std::vector<const std::vector<Viewpoint>*> target_views;
  for (std::size_t i = 0; i < views.size(); ++i)
    if (!views[i].empty()) {
      targets.push_back({frontiers.clusters()[i].id, {views[i].front().position_W, views[i].front().yaw_rad}});
      target_views.push_back(&views[i]);
    }
  VehicleState vehicle;
  vehicle.position_W = start;
  PathConfig cost_path;  // paths for costs: a shorter RRTConnect budget than for flying
  cost_path.time_limit_s = argc > 2 ? std::atof(argv[2]) : 0.01;
  double pairs_ms = 0, tour_ms = 0, refine_ms = 0, traj_ms = 0;
  std::size_t pairs = 0, refined_edges = 0;
  GlobalTour global;
  RefinementResult refined;
  TrajectoryResult traj;
  PathResult path;
  for (int r = 0; r < repeats; ++r) {
    PairCostTable table(CostConfig{}, cost_path);
    Stopwatch watch;
    pairs = table.update(map, targets);
    pairs_ms += watch.ms() / repeats;
    watch.restart();
    global = planGlobalTour(map, vehicle, targets, table);  // table already filled: legs + solve
    tour_ms += watch.ms() / repeats;
    watch.restart();
    std::vector<std::vector<Viewpoint>> in_order;
    for (const std::size_t i : global.tour.order) in_order.push_back(*target_views[i]);
    const auto layers = refinementLayers(vehicle, in_order);
    refined_edges = 0;
    for (std::size_t l = 0; l < layers.size(); ++l) refined_edges += layers[l].size() * (l ? layers[l - 1].size() : 1);
    refined = refineLocalTour(map, vehicle, layers, CostConfig{}, cost_path);
    refine_ms += watch.ms() / repeats;
    watch.restart();
    const Viewpoint& next = layers[0][refined.choice[0]];
    PathPlanner planner(map);
    path = planner.plan(vehicle.position_W, next.position_W);
    if (path.ok()) traj = planTrajectory(path.waypoints, vehicle, next.yaw_rad, map);
    traj_ms += watch.ms() / repeats;
  }
  std::cout << nlohmann::json{{"stage", "pair_costs"}, {"ms_mean", pairs_ms}, {"pairs", pairs}}.dump() << std::endl;
  std::cout << nlohmann::json{{"stage", "vehicle_legs_and_tour"},
                              {"ms_mean", tour_ms},
                              {"targets", targets.size()},
                              {"tour_cost_s", global.tour.cost_s},
                              {"optimal_proven", global.tour.optimal_proven}}
                   .dump()
            << std::endl;
  std::cout << nlohmann::json{{"stage", "local_refinement"}, {"ms_mean", refine_ms}, {"edges", refined_edges}}.dump()
            << std::endl;
  std::cout << nlohmann::json{{"stage", "path_and_trajectory"},
                              {"ms_mean", traj_ms},
                              {"path", toString(path.status)},
                              {"trajectory", toString(traj.status)},
                              {"duration_s", traj.trajectory.duration()}}
                   .dump()
            << std::endl;

  // The incremental step: the vehicle moves 2 m and turns again. After each frame only the box it
  // touched is rescanned (as the mapper reports dirty boxes); then only the pairs of new clusters
  // are planned, the table holding the pairs of the step before.
  PairCostTable table(CostConfig{}, cost_path);
  table.update(map, targets);
  std::vector<double> update_ms;
  openvdb::CoordBBox dirty;
  std::size_t added = 0, removed = 0;
  for (int i = 0; i < 12; ++i) {
    const Pose3d T = vdbmap::lookingPose(Vec3d(2.0, 0.5, 1.3), 2.0 * M_PI * i / 12, 0.0);
    const CameraIntrinsics K;
    const openvdb::CoordBBox box =
        volume.integrate(FrameId(100 + i), backProject(scene.renderDepth(K, T, 30.0), K), T).touched_voxels;
    dirty.expand(box);
    const Stopwatch watch;
    const FrontierUpdate u = frontiers.update(map, box);
    update_ms.push_back(watch.ms());
    added += u.added.size();
    removed += u.removed.size();
  }
  std::sort(update_ms.begin(), update_ms.end());
  FrontierMap scratch(fp);
  const Stopwatch scratch_watch;
  scratch.rebuild(map);
  const double scratch_ms = scratch_watch.ms();
  std::vector<TourTarget> next_targets;
  for (const FrontierCluster& c : frontiers.clusters()) {
    const auto kept = std::find_if(targets.begin(), targets.end(), [&](const TourTarget& t) { return t.cluster == c.id; });
    if (kept != targets.end()) {
      next_targets.push_back(*kept);
      continue;
    }
    const std::vector<Viewpoint> v = computeViewpoints(c, map);
    if (!v.empty()) next_targets.push_back({c.id, {v.front().position_W, v.front().yaw_rad}});
  }
  const Stopwatch pairs_watch;
  const std::size_t new_pairs = table.update(map, next_targets);
  const double new_pairs_ms = pairs_watch.ms();
  std::cout << nlohmann::json{{"stage", "incremental"},
                              {"dirty_voxels", dirty.volume()},
                              {"frames", 12},
                              {"frontier_update_ms_median", update_ms[update_ms.size() / 2]},
                              {"frontier_update_ms_max", update_ms.back()},
                              {"frontier_rebuild_ms", scratch_ms},
                              {"same_as_rebuild", scratch.frontierVoxelCount() == frontiers.frontierVoxelCount() &&
                                                      scratch.clusters().size() == frontiers.clusters().size()},
                              {"clusters_added", added},
                              {"clusters_removed", removed},
                              {"clusters", frontiers.clusters().size()},
                              {"pairs_planned", new_pairs},
                              {"pair_update_ms", new_pairs_ms}}
                   .dump()
            << std::endl;
  std::cout << nlohmann::json{{"stage", "full_plan"},
                              {"ms", pairs_ms + tour_ms + refine_ms + traj_ms},
                              {"note", "pair table from scratch + vehicle legs + tour + refinement + path/trajectory"}}
                   .dump()
            << std::endl;
  return 0;
}
