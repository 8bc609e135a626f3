// The ATSP solver on TSPLIB instances against their known optima: every instance listed in
// DIR/OPTIMA.txt ("name optimum" per line) is read from DIR/name.atsp and solved once per seed.
// One JSON line per run, then a table per instance over the seeds.
//
//   cmake --build build --target vdbmap_bench_atsp
//   build/bin/vdbmap_bench_atsp ../shared/data/tsplib_atsp [--time-limit-s S] [--seeds K] [--first-seed N]
//
// Without --time-limit-s the limits are the goals of issue 6: 1 s for n <= 171, 2 s beyond.
// time_to_best_s is when the returned tour was first found; time_s is the whole run, which ends
// early only when the tour is proven optimal.
#include "vdbmap/planner/atsp.hpp"
#include "vdbmap/planner/tsplib.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

using namespace vdbmap::planner;

namespace {

struct Row {
  std::string name;
  std::size_t n = 0;
  std::int64_t optimum = 0, best = 0, worst = 0;
  int runs = 0, optimal_runs = 0, proven_runs = 0;
  double limit_s = 0, sum_time_to_best = 0, max_time_to_best = 0, max_time = 0;
};

[[noreturn]] void usage(const char* what) {
  std::fprintf(stderr, "%s\nusage: vdbmap_bench_atsp DIR [--time-limit-s S] [--seeds K] [--first-seed N]\n", what);
  std::exit(2);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) usage("missing DIR");
  const std::filesystem::path dir = argv[1];
  double fixed_limit_s = 0.0;
  int seeds = 1;
  std::uint64_t first_seed = 1;
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    if (i + 1 >= argc) usage(("missing value after " + arg).c_str());
    if (arg == "--time-limit-s")
      fixed_limit_s = std::atof(argv[++i]);
    else if (arg == "--seeds")
      seeds = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--first-seed")
      first_seed = std::strtoull(argv[++i], nullptr, 10);
    else
      usage(("unknown option " + arg).c_str());
  }
  std::ifstream optima(dir / "OPTIMA.txt");
  if (!optima) usage(("cannot open " + (dir / "OPTIMA.txt").string()).c_str());

  std::vector<Row> rows;
  std::string name;
  std::int64_t optimum = 0;
  while (optima >> name >> optimum) {
    const TsplibInstance instance = readTsplib(dir / (name + ".atsp"));
    Row row;
    row.name = name;
    row.n = instance.costs.size();
    row.optimum = optimum;
    row.limit_s = fixed_limit_s > 0 ? fixed_limit_s : (row.n <= 171 ? 1.0 : 2.0);
    for (int s = 0; s < seeds; ++s) {
      AtspConfig options;
      options.time_limit_s = row.limit_s;
      options.seed = first_seed + std::uint64_t(s);
      const AtspResult r = solveAtsp(instance.costs, options);
      const double gap_pct = 100.0 * double(r.cost - optimum) / double(optimum);
      std::cout << nlohmann::json{{"name", name},
                                  {"n", row.n},
                                  {"seed", options.seed},
                                  {"cost", r.cost},
                                  {"optimum", optimum},
                                  {"gap_pct", gap_pct},
                                  {"lower_bound", r.lower_bound},
                                  {"optimal_proven", r.optimal_proven},
                                  {"time_s", r.time_s},
                                  {"time_to_best_s", r.time_to_best_s},
                                  {"iterations", r.iterations}}
                       .dump()
                << std::endl;
      row.best = s == 0 ? r.cost : std::min(row.best, r.cost);
      row.worst = s == 0 ? r.cost : std::max(row.worst, r.cost);
      ++row.runs;
      row.optimal_runs += r.cost == optimum;
      row.proven_runs += r.optimal_proven;
      row.sum_time_to_best += r.time_to_best_s;
      row.max_time_to_best = std::max(row.max_time_to_best, r.time_to_best_s);
      row.max_time = std::max(row.max_time, r.time_s);
    }
    rows.push_back(row);
  }

  std::printf("\n%-8s %4s %8s %8s %8s %9s %8s %7s %10s %10s %8s\n", "name", "n", "optimum", "best", "worst",
              "worst_gap%", "optimal", "proven", "mean_tbest", "max_tbest", "max_time");
  for (const Row& r : rows) {
    std::printf("%-8s %4zu %8lld %8lld %8lld %9.3f %5d/%-2d %4d/%-2d %9.3fs %9.3fs %7.3fs\n", r.name.c_str(), r.n,
                (long long)r.optimum, (long long)r.best, (long long)r.worst,
                100.0 * double(r.worst - r.optimum) / double(r.optimum), r.optimal_runs, r.runs, r.proven_runs, r.runs,
                r.sum_time_to_best / r.runs, r.max_time_to_best, r.max_time);
  }
  return 0;
}
