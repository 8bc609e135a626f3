// Cost-leg searches compared on a saved map: OMPL's RRTConnect with exploration's counted budget
// (300 iterations) and with 20 times that, against A* on the lattice (grid_search.hpp) in its
// settings and as RRTConnect's fallback. The legs
// join random points that are clear at the planner's clearance and whose straight segment is
// blocked, as the tour's legs that need a search. Reports, per search: legs found, iterations or
// expansions, time (median, p99, total, one thread) and, over legs every search found, the path
// length against the default lattice search's; then which legs each finds that RRTConnect (300)
// does not, and the reverse.
//
//   cmake --build build --target vdbmap_bench_cost_legs
//   build/bin/vdbmap_bench_cost_legs RUNDIR [legs=300] [seed=1]
// RUNDIR is an `explore -o` folder (map.vdb, summary.json); `--max-time-s` cuts a run where its
// map is still partly unknown, as the planner sees it.
#include "vdbmap/planner/cached_map.hpp"
#include "vdbmap/planner/path_planner.hpp"
#include "vdbmap/planner/tsdf_map_query.hpp"
#include "vdbmap/timing.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

using namespace vdbmap;
using namespace vdbmap::planner;

namespace {

Vec3d vec3(const nlohmann::json& j) {
  return Vec3d(j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>());
}

struct Method {
  std::string name;
  PathConfig config;
};

struct Outcome {
  bool found = false;
  double length_m = 0.0;
  double ms = 0.0;
  std::uint64_t iterations = 0;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s RUNDIR [legs=300] [seed=1]\n", argv[0]);
    return 2;
  }
  const std::filesystem::path run_dir = argv[1];
  const int legs = argc > 2 ? std::atoi(argv[2]) : 300;
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

  PathConfig base;
  base.bounds_W = box;
  base.time_limit_s = 30.0;  // the counted budgets bind
  std::vector<Method> methods;
  {
    Method m{"rrt_connect_300", base};
    m.config.max_iterations = 300;
    methods.push_back(m);
    m = {"rrt_connect_6000", base};
    m.config.max_iterations = 6000;
    methods.push_back(m);
    m = {"rrt_300_then_grid", base};
    m.config.search = PathSearch::SamplingThenGrid;
    m.config.max_iterations = 300;
    methods.push_back(m);
    m = {"grid_stride_1", base};
    m.config.search = PathSearch::Grid;
    m.config.grid.stride_vox = 1;
    methods.push_back(m);
    m = {"grid_weight_1", base};
    m.config.search = PathSearch::Grid;
    m.config.grid.heuristic_weight = 1.0;
    methods.push_back(m);
    m = {"grid", base};  // the defaults: stride 2, weight 2
    m.config.search = PathSearch::Grid;
    methods.push_back(m);
  }

  // Legs: clear ends, blocked straight segment, at most 30 m apart.
  std::vector<std::pair<Vec3d, Vec3d>> pairs;
  {
    const CachedMap map(tsdf);
    PathPlanner probe(map, base);
    std::mt19937_64 rng(seed);
    const Eigen::AlignedBox3d search = probe.searchBounds();
    std::uniform_real_distribution<double> ux(search.min().x(), search.max().x()),
        uy(search.min().y(), search.max().y()), uz(search.min().z(), search.max().z());
    auto clearPoint = [&] {
      for (;;) {
        const Vec3d p(ux(rng), uy(rng), uz(rng));
        if (probe.isClear(p)) return p;
      }
    };
    while (int(pairs.size()) < legs) {
      const Vec3d a = clearPoint(), b = clearPoint();
      if ((a - b).norm() <= 30.0 && !probe.isSegmentClear(a, b)) pairs.emplace_back(a, b);
    }
  }

  std::vector<std::vector<Outcome>> outcomes(methods.size(), std::vector<Outcome>(pairs.size()));
  for (std::size_t m = 0; m < methods.size(); ++m) {
    const CachedMap map(tsdf);  // each method fills its own blocks, as a replan does
    std::unique_ptr<PathPlanner> planner;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      if (i % 8 == 0) planner = std::make_unique<PathPlanner>(map, methods[m].config);  // a task's legs
      const Stopwatch watch;
      const PathResult r = planner->plan(pairs[i].first, pairs[i].second, i);
      outcomes[m][i] = Outcome{r.ok(), r.length_m, watch.ms(), r.iterations};
    }
  }

  std::printf("%zu legs with a blocked straight segment, %s\n", pairs.size(), run_dir.c_str());
  std::printf(
      "| search | found | iterations (mean) | ms median | ms p99 | ms max | total s | length / lattice's (median, max) "
      "|\n");
  std::printf("| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |\n");
  const std::size_t grid = methods.size() - 1;
  for (std::size_t m = 0; m < methods.size(); ++m) {
    std::vector<double> ms, ratio;
    int found = 0;
    double total = 0.0;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      const Outcome& o = outcomes[m][i];
      ms.push_back(o.ms);
      total += o.ms;
      found += o.found;
      bool all = true;
      for (std::size_t k = 0; k < methods.size(); ++k) all = all && outcomes[k][i].found;
      if (all) ratio.push_back(o.length_m / outcomes[grid][i].length_m);
    }
    double iterations = 0;
    for (const Outcome& o : outcomes[m]) iterations += double(o.iterations);
    std::sort(ms.begin(), ms.end());
    std::sort(ratio.begin(), ratio.end());
    auto at = [](const std::vector<double>& v, double q) {
      return v.empty() ? 0.0 : v[std::size_t(q * (v.size() - 1))];
    };
    std::printf("| %s | %d | %.0f | %.2f | %.2f | %.2f | %.3f | %.3f, %.3f |\n", methods[m].name.c_str(), found,
                iterations / double(pairs.size()), at(ms, 0.5), at(ms, 0.99), ms.back(), total / 1000.0, at(ratio, 0.5),
                ratio.empty() ? 0.0 : ratio.back());
  }
  for (std::size_t m = 1; m < methods.size(); ++m) {
    int gained = 0, lost = 0;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      gained += outcomes[m][i].found && !outcomes[0][i].found;
      lost += !outcomes[m][i].found && outcomes[0][i].found;
    }
    std::printf("%s against %s: finds %d more, misses %d\n", methods[m].name.c_str(), methods[0].name.c_str(), gained,
                lost);
  }
  return 0;
}
