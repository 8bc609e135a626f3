// Trajectory time along exploration's flight paths on a saved map: the corner rules of stop 55
// (TrajectoryConfig::corner_relax_m, and from a moving start the lead-in that arrives first)
// against the rule before them (corners as the path gives them, the shortest lead-in that keeps
// the vehicle's velocity; reproduced here by passing that lead-in as the path's first leg).
// Paths join random clear points at most 12 m apart (a replan's reach) with the flight path
// search; starts are at rest, and moving at 0.5-2 m/s in a random level direction whose first
// metre is clear (a replan while flying, toward a target in another direction). Reports per
// variant: trajectories, motion time in all and its median ratio to the old rule's, the slowest
// speed between the first and last metre (median), and planning time (median, p99, max, one
// thread).
//
//   cmake --build build --target vdbmap_bench_trajectory
//   build/bin/vdbmap_bench_trajectory RUNDIR [paths=300] [seed=1]
// RUNDIR is an `explore -o` folder (map.vdb, summary.json).
#include "vdbmap/planner/cached_map.hpp"
#include "vdbmap/planner/exploration_manager.hpp"
#include "vdbmap/planner/path_planner.hpp"
#include "vdbmap/planner/trajectory.hpp"
#include "vdbmap/planner/tsdf_map_query.hpp"
#include "vdbmap/timing.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <vector>

using namespace vdbmap;
using namespace vdbmap::planner;

namespace {

Vec3d vec3(const nlohmann::json& j) {
  return Vec3d(j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>());
}

struct Case {
  std::vector<Vec3d> path;
  VehicleState start;
};

struct Outcome {
  double motion_s = 0.0;
  double slowest_m_s = 0.0;
  double ms = 0.0;
};

/// The slowest speed between the first and the last metre of the motion (sampled every 10 ms).
double slowestInside(const Trajectory& t) {
  double v_min = std::numeric_limits<double>::infinity(), s = 0.0;
  Vec3d prev = t.sample(0.0).position_W;
  for (double time = 0.0; time <= t.motionDuration(); time += 0.01) {
    const VehicleState st = t.sample(time);
    s += (st.position_W - prev).norm();
    prev = st.position_W;
    if (s >= 1.0 && s <= t.length_m() - 1.0) v_min = std::min(v_min, st.velocity_W.norm());
  }
  return std::isfinite(v_min) ? v_min : 0.0;
}

/// The rule before stop 55: corners as given, and the first lead-in (0.6, 1.2, 2, 3 braking
/// distances) whose trajectory keeps the start velocity.
std::optional<Trajectory> oldRule(const Case& c, const MapQuery& map, TrajectoryConfig cfg) {
  cfg.corner_relax_m = 0.0;
  // A trajectory the builder made without a lead-in of its own (it inserts one corner).
  auto asGiven = [](const TrajectoryResult& r, const std::vector<Vec3d>& path) {
    return r.status == TrajectoryStatus::Ok && r.trajectory.corners().size() == path.size();
  };
  const TrajectoryResult plain = planTrajectory(c.path, c.start, 0.0, map, cfg);
  if (asGiven(plain, c.path)) return plain.trajectory;
  const Vec3d v0 = c.start.velocity_W;
  const double speed0 = v0.norm();
  if (speed0 <= 0.0) return std::nullopt;
  const double brake_m = speed0 * speed0 / (2.0 * cfg.a_max_m_s2);
  for (const double f : {0.6, 1.2, 2.0, 3.0}) {
    std::vector<Vec3d> with_lead = c.path;
    with_lead.insert(with_lead.begin() + 1, c.path.front() + v0 / speed0 * std::max(f * brake_m, map.voxelSize()));
    const TrajectoryResult r = planTrajectory(with_lead, c.start, 0.0, map, cfg);
    if (asGiven(r, with_lead)) return r.trajectory;
  }
  return std::nullopt;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::size_t(q * double(v.size() - 1))];
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s RUNDIR [paths=300] [seed=1]\n", argv[0]);
    return 2;
  }
  const std::filesystem::path run_dir = argv[1];
  const int paths = argc > 2 ? std::atoi(argv[2]) : 300;
  const unsigned seed = argc > 3 ? unsigned(std::atoi(argv[3])) : 1u;
  initializeOpenVdb();
  std::ifstream summary_file(run_dir / "summary.json");
  if (!summary_file) {
    std::fprintf(stderr, "%s: cannot open\n", (run_dir / "summary.json").c_str());
    return 1;
  }
  const nlohmann::json summary = nlohmann::json::parse(summary_file);
  const Eigen::AlignedBox3d box(vec3(summary.at("box").at("min")), vec3(summary.at("box").at("max")));
  const TsdfVolume volume = TsdfVolume::load(run_dir / "map.vdb");
  const TsdfMapQuery tsdf(volume);
  const CachedMap map(tsdf);

  PathConfig path_config = ExplorationManagerConfig::flightPathDefaults();
  path_config.bounds_W = box;
  path_config.time_limit_s = 30.0;
  path_config.max_iterations = 3000;  // exploration's counted budget
  const TrajectoryConfig defaults;

  // Cases: half from rest, half moving.
  std::vector<Case> cases;
  {
    PathPlanner planner(map, path_config);
    std::mt19937_64 rng(seed);
    const Eigen::AlignedBox3d search = planner.searchBounds();
    std::uniform_real_distribution<double> ux(search.min().x(), search.max().x()),
        uy(search.min().y(), search.max().y()), uz(search.min().z(), search.max().z()), unit(0.0, 1.0);
    auto clearPoint = [&] {
      for (;;) {
        const Vec3d p(ux(rng), uy(rng), uz(rng));
        if (planner.isClear(p)) return p;
      }
    };
    while (int(cases.size()) < paths) {
      const Vec3d a = clearPoint(), b = clearPoint();
      if ((a - b).norm() > 12.0 || (a - b).norm() < 1.0) continue;
      const PathResult r = planner.plan(a, b, cases.size());
      if (!r.ok()) continue;
      Case c{r.waypoints, VehicleState{}};
      c.start.position_W = a;
      if (cases.size() % 2 == 1) {
        const double heading = 2.0 * M_PI * unit(rng), speed = 0.5 + 1.5 * unit(rng);
        const Vec3d dir(std::cos(heading), std::sin(heading), 0.0);
        if (!planner.isSegmentClear(a, a + dir)) continue;
        c.start.velocity_W = speed * dir;
      }
      cases.push_back(std::move(c));
    }
  }

  struct Variant {
    std::string name;
    TrajectoryConfig config;
  };
  TrajectoryConfig no_relax = defaults;
  no_relax.corner_relax_m = 0.0;
  const std::vector<Variant> variants{{"fastest lead-in, corners as given", no_relax},
                                      {"fastest lead-in, corners relaxed (default)", defaults}};

  std::vector<std::optional<Outcome>> old_outcomes(cases.size());
  std::vector<std::vector<std::optional<Outcome>>> outcomes(variants.size(),
                                                            std::vector<std::optional<Outcome>>(cases.size()));
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const Stopwatch watch;
    if (const std::optional<Trajectory> t = oldRule(cases[i], map, defaults))
      old_outcomes[i] = Outcome{t->motionDuration(), slowestInside(*t), watch.ms()};
    for (std::size_t v = 0; v < variants.size(); ++v) {
      const Stopwatch w;
      const TrajectoryResult r = planTrajectory(cases[i].path, cases[i].start, 0.0, map, variants[v].config);
      const double ms = w.ms();
      if (r.status == TrajectoryStatus::Ok)
        outcomes[v][i] = Outcome{r.trajectory.motionDuration(), slowestInside(r.trajectory), ms};
    }
  }

  std::printf("%zu paths (every other start moving), %s\n", cases.size(), run_dir.c_str());
  std::printf(
      "| rule | starts | trajectories | motion s in all | median ratio to before | slowest inside, m/s (median) | plan "
      "ms "
      "median / p99 / max |\n");
  std::printf("| --- | --- | ---: | ---: | ---: | ---: | --- |\n");
  for (const char* starts :
       {"at rest", "moving", "at rest, slowing below 1.5 m/s before", "moving, slowing below 1.5 m/s before"}) {
    const std::string label(starts);
    const std::size_t parity = label.rfind("moving", 0) == 0 ? 1 : 0;
    const bool slowing_only = label.find("slowing") != std::string::npos;
    auto comparable = [&](std::size_t i) {
      if (i % 2 != parity || !old_outcomes[i]) return false;
      if (slowing_only && old_outcomes[i]->slowest_m_s >= 1.5) return false;
      for (const auto& o : outcomes)
        if (!o[i]) return false;
      return true;
    };
    auto row = [&](const std::string& name, const std::vector<std::optional<Outcome>>& o, bool with_ms) {
      double total = 0.0;
      std::vector<double> ratio, slowest, ms;
      for (std::size_t i = 0; i < cases.size(); ++i) {
        if (!comparable(i)) continue;
        total += o[i]->motion_s;
        ratio.push_back(o[i]->motion_s / old_outcomes[i]->motion_s);
        slowest.push_back(o[i]->slowest_m_s);
        ms.push_back(o[i]->ms);
      }
      const std::string plan_ms = with_ms ? std::to_string(quantile(ms, 0.5)).substr(0, 5) + " / " +
                                                std::to_string(quantile(ms, 0.99)).substr(0, 5) + " / " +
                                                std::to_string(quantile(ms, 1.0)).substr(0, 5)
                                          : "-";
      std::printf("| %s | %s | %zu | %.1f | %.3f | %.2f | %s |\n", name.c_str(), starts, ratio.size(), total,
                  quantile(ratio, 0.5), quantile(slowest, 0.5), plan_ms.c_str());
    };
    row("before (shortest lead-in, corners as given)", old_outcomes, false);
    for (std::size_t v = 0; v < variants.size(); ++v) row(variants[v].name, outcomes[v], true);
  }
  int old_only = 0, new_only = 0;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    old_only += old_outcomes[i] && !outcomes.back()[i];
    new_only += !old_outcomes[i] && outcomes.back()[i];
  }
  std::printf("start velocity kept: by the rule before only %d, by the default only %d\n", old_only, new_only);
  return 0;
}
