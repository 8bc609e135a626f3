// The ATSP solver at the planner's budgets: open paths from the vehicle over nearly symmetric
// travel-time costs (FUEL's max(distance / v_max, |yaw difference| / yaw_rate_max), plus a
// heading term on the arcs leaving the vehicle), solved with 5 and 20 ms limits. The gap is
// against a reference: the proven optimum for n <= 16, else the best of 3 seeds x 0.3 s (not
// proven). One JSON line per (n, limit), then a table.
//
//   cmake --build build --target vdbmap_bench_atsp_planner
//   build/bin/vdbmap_bench_atsp_planner [instances per size, default 16]
#include "vdbmap/planner/atsp.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <random>
#include <vector>

using namespace vdbmap::planner;

namespace {

constexpr double kVMax = 2.0, kYawRateMax = 0.9;  // the paper's simulation limits

/// n viewpoints (node 0 = the vehicle) in a 20 x 20 x 2 m box with random yaw.
RealCostMatrix plannerLikeCosts(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> xy(0.0, 20.0), z(0.0, 2.0), yaw(-M_PI, M_PI);
  const auto count = static_cast<std::size_t>(n);
  std::vector<double> px(count), py(count), pz(count), pyaw(count);
  for (std::size_t i = 0; i < count; ++i) {
    px[i] = xy(rng);
    py[i] = xy(rng);
    pz[i] = z(rng);
    pyaw[i] = yaw(rng);
  }
  RealCostMatrix costs(count);
  for (std::size_t i = 0; i < count; ++i) {
    for (std::size_t j = 0; j < count; ++j) {
      const double distance = std::sqrt((px[i] - px[j]) * (px[i] - px[j]) + (py[i] - py[j]) * (py[i] - py[j]) +
                                        (pz[i] - pz[j]) * (pz[i] - pz[j]));
      const double turn = std::fabs(std::remainder(pyaw[j] - pyaw[i], 2.0 * M_PI));
      costs(i, j) = std::max(distance / kVMax, turn / kYawRateMax);
      if (i == 0) costs(i, j) += 0.5 * std::fabs(std::atan2(py[j] - py[0], px[j] - px[0]));  // heading change
    }
  }
  return costs;
}

std::int64_t reference(const RealCostMatrix& costs, int n) {
  AtspConfig options;
  options.open_from = 0;
  if (n <= 16) {
    options.time_limit_s = 60.0;
    return solveAtsp(costs, options).cost;  // exact DP
  }
  std::int64_t best = std::numeric_limits<std::int64_t>::max();
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    options.time_limit_s = 0.3;
    options.seed = seed;
    best = std::min(best, solveAtsp(costs, options).cost);
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  const int instances = argc > 1 ? std::max(1, std::atoi(argv[1])) : 16;
  const std::vector<int> sizes = {10, 16, 25, 35, 50, 80};
  const std::vector<double> limits_s = {0.005, 0.020};
  struct Row {
    int n;
    double limit_s;
    int at_reference = 0, proven = 0;
    double mean_gap_pct = 0, max_gap_pct = 0, mean_time_s = 0, max_time_s = 0;
  };
  std::vector<Row> rows;
  for (const int n : sizes) {
    std::vector<RealCostMatrix> matrices;
    std::vector<std::int64_t> refs;
    for (int k = 0; k < instances; ++k) {
      matrices.push_back(plannerLikeCosts(n, std::uint64_t(1000 * n + k)));
      refs.push_back(reference(matrices.back(), n));
    }
    for (const double limit_s : limits_s) {
      Row row{n, limit_s};
      for (int k = 0; k < instances; ++k) {
        AtspConfig options;
        options.open_from = 0;
        options.time_limit_s = limit_s;
        const AtspResult r = solveAtsp(matrices[std::size_t(k)], options);
        const double gap = 100.0 * double(r.cost - refs[std::size_t(k)]) / double(refs[std::size_t(k)]);
        row.at_reference += r.cost <= refs[std::size_t(k)];
        row.proven += r.optimal_proven;
        row.mean_gap_pct += gap / instances;
        row.max_gap_pct = std::max(row.max_gap_pct, gap);
        row.mean_time_s += r.time_s / instances;
        row.max_time_s = std::max(row.max_time_s, r.time_s);
      }
      std::cout << nlohmann::json{{"n", n},
                                  {"time_limit_s", limit_s},
                                  {"instances", instances},
                                  {"at_reference", row.at_reference},
                                  {"proven", row.proven},
                                  {"mean_gap_pct", row.mean_gap_pct},
                                  {"max_gap_pct", row.max_gap_pct},
                                  {"mean_time_s", row.mean_time_s},
                                  {"max_time_s", row.max_time_s}}
                       .dump()
                << std::endl;
      rows.push_back(row);
    }
  }
  std::printf("\n%4s %6s %12s %7s %9s %9s %9s %9s\n", "n", "limit", "at_reference", "proven", "mean_gap%", "max_gap%",
              "mean_time", "max_time");
  for (const Row& r : rows)
    std::printf("%4d %4.0fms %9d/%-2d %4d/%-2d %9.3f %9.3f %7.1fms %7.1fms\n", r.n, r.limit_s * 1e3, r.at_reference,
                instances, r.proven, instances, r.mean_gap_pct, r.max_gap_pct, r.mean_time_s * 1e3, r.max_time_s * 1e3);
  return 0;
}
