// The ATSP solver against brute force on small random instances (closed tours and open paths,
// exact DP and local-search paths), on TSPLIB instances with known optima, and its contract:
// permutations, recomputed costs, no overflow on "unreachable" costs, the time limit.
#include "vdbmap/planner/atsp.hpp"
#include "vdbmap/planner/tsplib.hpp"

#include "common/shared_data.hpp"
#include "planner/planner_test_maps.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numeric>
#include <random>

using namespace vdbmap::planner;

namespace {

const std::filesystem::path kTsplib = vdbmap::test::sharedDataDir() / "tsplib_atsp";

/// Cost of `order` recomputed here, independently of the solver (no clamping needed: test costs are small).
std::int64_t recomputedCost(const CostMatrix& costs, const std::vector<std::size_t>& order, bool closed) {
  std::int64_t sum = 0;
  for (std::size_t i = 0; i + 1 < order.size(); ++i) sum += costs(order[i], order[i + 1]);
  if (closed && order.size() > 1) sum += costs(order.back(), order.front());
  return sum;
}

bool isPermutation(std::vector<std::size_t> order, std::size_t n) {
  std::sort(order.begin(), order.end());
  for (std::size_t i = 0; i < order.size(); ++i)
    if (order[i] != i) return false;
  return order.size() == n;
}

/// Best cost over all tours (closed: node 0 first) or all paths from `start`, by enumeration.
std::int64_t bruteForce(const CostMatrix& costs, std::optional<std::size_t> start) {
  const std::size_t n = costs.size();
  const std::size_t first = start.value_or(0);
  std::vector<std::size_t> rest;
  for (std::size_t i = 0; i < n; ++i)
    if (i != first) rest.push_back(i);
  std::int64_t best = std::numeric_limits<std::int64_t>::max();
  do {
    std::vector<std::size_t> order{first};
    order.insert(order.end(), rest.begin(), rest.end());
    best = std::min(best, recomputedCost(costs, order, !start));
  } while (std::next_permutation(rest.begin(), rest.end()));
  return best;
}

/// Random costs; `max_cost` small gives many ties, as on the rbg instances.
CostMatrix randomCosts(std::size_t n, std::int64_t max_cost, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  CostMatrix costs(n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j) costs(i, j) = i == j ? 777 : std::int64_t(rng() % std::uint64_t(max_cost + 1));
  return costs;
}

/// Rounded distances between random points in a 100 x 100 square: symmetric, like the planner's
/// travel times, where segment reversals matter.
CostMatrix euclideanCosts(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<double> x(n), y(n);
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = double(rng() % 10000) / 100.0;
    y[i] = double(rng() % 10000) / 100.0;
  }
  CostMatrix costs(n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j) costs(i, j) = std::llround(std::hypot(x[i] - x[j], y[i] - y[j]));
  return costs;
}

/// Three kinds of small instances by seed: distinct asymmetric costs, heavy ties, symmetric.
CostMatrix mixedCosts(std::size_t n, std::uint64_t seed) {
  switch (seed % 3) {
    case 0:
      return randomCosts(n, 1000, seed);
    case 1:
      return randomCosts(n, 3, seed);
    default:
      return euclideanCosts(n, seed);
  }
}

/// The contract every result keeps: a permutation, starting where it must, whose cost is what
/// the matrix says.
void checkResult(const CostMatrix& costs, const AtspResult& r, std::optional<std::size_t> open_from) {
  REQUIRE(isPermutation(r.order, costs.size()));
  if (!r.order.empty()) CHECK(r.order.front() == open_from.value_or(0));
  CHECK(r.cost == recomputedCost(costs, r.order, !open_from));
  CHECK(r.cost == tourCost(costs, r.order, !open_from));
  CHECK(r.optimal_proven == (r.status == AtspStatus::kOptimal));
  if (r.lower_bound != std::numeric_limits<std::int64_t>::min()) CHECK(r.lower_bound <= r.cost);
}

}  // namespace

TEST_CASE("exact DP matches brute force on random instances, closed and open, n <= 9", "[atsp]") {
  for (std::size_t n = 1; n <= 9; ++n) {
    for (std::uint64_t seed = 0; seed < 6; ++seed) {
      const CostMatrix costs = mixedCosts(n, 99 * n + seed);
      for (const std::optional<std::size_t> open_from :
           {std::optional<std::size_t>(), std::optional<std::size_t>(n - 1)}) {
        AtspConfig options;
        options.open_from = open_from;
        options.time_limit_s = 10.0;
        const AtspResult r = solveAtsp(costs, options);
        INFO("n " << n << " seed " << seed << (open_from ? " open" : " closed"));
        checkResult(costs, r, open_from);
        CHECK(r.cost == bruteForce(costs, open_from));
        CHECK(r.optimal_proven);
        CHECK(r.lower_bound == r.cost);
      }
    }
  }
}

TEST_CASE("local search without the DP matches brute force on random instances, closed and open, n <= 9", "[atsp]") {
  for (std::size_t n = 4; n <= 9; ++n) {
    for (std::uint64_t seed = 0; seed < 9; ++seed) {
      const CostMatrix costs = mixedCosts(n, 999 * n + seed);
      for (const std::optional<std::size_t> open_from :
           {std::optional<std::size_t>(), std::optional<std::size_t>(n / 2)}) {
        AtspConfig options;
        options.open_from = open_from;
        options.exact_max_n = 0;  // force the heuristic path
        options.max_iterations = 300;
        options.time_limit_s = 10.0;
        options.seed = seed;
        const AtspResult r = solveAtsp(costs, options);
        INFO("n " << n << " seed " << seed << (open_from ? " open" : " closed"));
        checkResult(costs, r, open_from);
        const std::int64_t optimum = bruteForce(costs, open_from);
        CHECK(r.cost == optimum);
        CHECK(r.lower_bound <= optimum);  // the assignment bound
        // Proven only when the bound is met; otherwise the 300 rounds ran out.
        CHECK(r.status == (r.lower_bound == r.cost ? AtspStatus::kOptimal : AtspStatus::kIterationLimit));
      }
    }
  }
}

TEST_CASE("open paths ignore the return arcs: a path can beat every tour", "[atsp]") {
  // A chain 0 -> 1 -> 2 -> 3 of cost 1 per arc; every arc back costs 100.
  CostMatrix costs(4, 100);
  costs(0, 1) = costs(1, 2) = costs(2, 3) = 1;
  AtspConfig options;
  options.open_from = 0;
  const AtspResult path = solveAtsp(costs, options);
  CHECK(path.order == std::vector<std::size_t>{0, 1, 2, 3});
  CHECK(path.cost == 3);
  options.open_from.reset();
  const AtspResult tour = solveAtsp(costs, options);
  CHECK(tour.cost == 103);
  options.open_from = 2;  // from 2 the chain must be left
  const AtspResult from2 = solveAtsp(costs, options);
  checkResult(costs, from2, 2);
  CHECK(from2.cost == bruteForce(costs, 2));
}

TEST_CASE("degenerate sizes 0 to 3 are solved exactly", "[atsp]") {
  AtspConfig options;
  const AtspResult empty = solveAtsp(CostMatrix(0), options);
  CHECK(empty.order.empty());
  CHECK(empty.optimal_proven);
  for (std::size_t n = 1; n <= 3; ++n) {
    const CostMatrix costs = randomCosts(n, 50, n);
    options.open_from.reset();
    checkResult(costs, solveAtsp(costs, options), std::nullopt);
    CHECK(solveAtsp(costs, options).cost == bruteForce(costs, std::nullopt));
    options.open_from = n - 1;
    CHECK(solveAtsp(costs, options).cost == bruteForce(costs, n - 1));
  }
}

TEST_CASE("TSPLIB br17 = 39 and ftv33 = 1286 are found", "[atsp][tsplib]") {
  vdbmap::test::requireSharedData("tsplib_atsp/br17.atsp");
  // A fixed round count (found within about 100 rounds) keeps the result independent of machine speed.
  AtspConfig options;
  options.time_limit_s = 10.0;
  options.max_iterations = 3000;
  const TsplibInstance br17 = readTsplib(kTsplib / "br17.atsp");
  const AtspResult r17 = solveAtsp(br17.costs, options);
  checkResult(br17.costs, r17, std::nullopt);
  CHECK(r17.cost == 39);
  options.exact_max_n = 17;  // the DP proves it (the assignment bound is 0 here)
  const AtspResult r17_exact = solveAtsp(br17.costs, options);
  CHECK(r17_exact.cost == 39);
  CHECK(r17_exact.optimal_proven);

  options.exact_max_n = AtspConfig{}.exact_max_n;
  const TsplibInstance ftv33 = readTsplib(kTsplib / "ftv33.atsp");
  const AtspResult r33 = solveAtsp(ftv33.costs, options);
  checkResult(ftv33.costs, r33, std::nullopt);
  CHECK(r33.cost == 1286);
  CHECK(r33.status == AtspStatus::kIterationLimit);  // its assignment bound (1185) proves nothing
}

TEST_CASE("a tour meeting the assignment bound is proven optimal and returned early (rbg323)", "[atsp][tsplib]") {
  vdbmap::test::requireSharedData("tsplib_atsp/rbg323.atsp");
  const TsplibInstance rbg = readTsplib(kTsplib / "rbg323.atsp");
  AtspConfig options;
  options.time_limit_s = 20.0;
  const AtspResult r = solveAtsp(rbg.costs, options);
  checkResult(rbg.costs, r, std::nullopt);
  CHECK(r.cost == 1326);
  CHECK(r.lower_bound == 1326);
  CHECK(r.optimal_proven);
  CHECK(r.time_s < options.time_limit_s / 2);  // it stopped at the proof, not at the limit
}

TEST_CASE("the time limit is respected within 10 % on a large random instance", "[atsp][time]") {
  // n = 600: the assignment bound (O(n^3)) takes a fraction of the limit, so the local search runs
  // too and the limit is what stops it. The solver works on the calling thread; the work it does
  // after the limit passes is measured in that thread's CPU time, so that time slices lost to
  // other processes cannot fail the test while a search that ignores its deadline still does.
  const CostMatrix costs = randomCosts(600, 100000, 42);
  AtspConfig options;
  options.time_limit_s = 0.5;
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start_s = test::threadCpuSeconds();
  const AtspResult r = solveAtsp(costs, options);
  const double cpu_s = test::threadCpuSeconds() - cpu_start_s;
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  checkResult(costs, r, std::nullopt);
  CHECK(r.status == AtspStatus::kTimeLimit);
  CHECK(wall_s >= options.time_limit_s);
  CHECK(cpu_s <= 1.1 * options.time_limit_s);
  CHECK(r.time_s <= wall_s);
  CHECK(r.iterations > 0);
}

TEST_CASE("the same seed and round count give the same tour", "[atsp]") {
  const CostMatrix costs = randomCosts(60, 20, 9);  // ties: many equally good tours to drift between
  AtspConfig options;
  options.time_limit_s = 30.0;
  options.max_iterations = 2000;
  options.seed = 5;
  options.open_from = 3;
  const AtspResult a = solveAtsp(costs, options);
  const AtspResult b = solveAtsp(costs, options);
  CHECK(a.order == b.order);
  CHECK(a.iterations == b.iterations);
  checkResult(costs, a, 3);
}

TEST_CASE("a settled search stops after max_stale_iterations rounds without a cheaper tour", "[atsp]") {
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const CostMatrix costs = mixedCosts(30, 77 + seed);
    AtspConfig options;
    options.time_limit_s = 30.0;
    options.max_iterations = 20000;
    options.max_stale_iterations = 300;
    options.seed = seed;
    options.open_from = 0;
    const AtspResult settled = solveAtsp(costs, options);
    INFO("seed " << seed << ": settled after " << settled.iterations << " rounds");
    checkResult(costs, settled, 0);
    if (settled.status == AtspStatus::kOptimal) continue;  // met the assignment bound first
    REQUIRE(settled.status == AtspStatus::kSettled);
    REQUIRE(settled.iterations >= 300);
    CHECK(settled.iterations < 20000);
    // The rounds are those of the unlimited search: stopped at the same round, it has the same tour,
    // and 300 rounds earlier it already had that tour's cost.
    options.max_stale_iterations = 0;
    options.max_iterations = settled.iterations;
    const AtspResult same = solveAtsp(costs, options);
    CHECK(same.order == settled.order);
    CHECK(same.status == AtspStatus::kIterationLimit);
    const std::uint64_t best_round = settled.iterations - 300;  // 0: the first descent's tour
    if (best_round < 2) continue;                               // (max_iterations 0 means no limit)
    options.max_iterations = best_round;
    CHECK(solveAtsp(costs, options).cost == settled.cost);
    options.max_iterations = best_round - 1;
    CHECK(solveAtsp(costs, options).cost > settled.cost);
  }
}

TEST_CASE("unreachable (huge) costs neither overflow nor get used when avoidable", "[atsp]") {
  constexpr std::int64_t kHuge = std::numeric_limits<std::int64_t>::max();
  for (const std::size_t n : {7, 40}) {  // exact and local-search paths
    // Only the ring i -> i+1 and a few random arcs are reachable.
    CostMatrix costs(n, kHuge);
    std::mt19937_64 rng(n);
    for (std::size_t i = 0; i < n; ++i) costs(i, (i + 1) % n) = 10 + std::int64_t(rng() % 5);
    for (int k = 0; k < 3 * int(n); ++k) costs(rng() % n, rng() % n) = std::int64_t(rng() % 30);
    AtspConfig options;
    options.time_limit_s = 10.0;  // the rounds, not the clock, end the local search
    options.max_iterations = 2000;
    const AtspResult r = solveAtsp(costs, options);
    REQUIRE(isPermutation(r.order, n));
    CHECK(r.cost == tourCost(costs, r.order, true));
    CHECK(r.cost < kMaxArcCost);  // a reachable tour exists, and it was found
  }
  // Nothing reachable: the cost is the clamped sum, not an overflow.
  const CostMatrix all_huge(30, kHuge);
  AtspConfig options;
  options.time_limit_s = 10.0;  // the bound's proof ends it
  const AtspResult r = solveAtsp(all_huge, options);
  CHECK(r.cost == 30 * kMaxArcCost);
  CHECK(r.optimal_proven);  // every tour costs the same: the assignment bound proves it
}

TEST_CASE("real-valued costs (seconds, +inf unreachable) are solved at the given resolution", "[atsp]") {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> seconds(0.5, 20.0);
  const std::size_t n = 8;
  RealCostMatrix real(n);
  CostMatrix scaled(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < n; ++j) {
      real(i, j) = (i + 2 * j) % 7 == 3 ? std::numeric_limits<double>::infinity() : seconds(rng);
      scaled(i, j) = std::isinf(real(i, j)) ? 1000000000 : std::llround(real(i, j) / 1e-3);
    }
  }
  AtspConfig options;
  options.open_from = 0;
  options.cost_resolution = 1e-3;
  const AtspResult r = solveAtsp(real, options);
  REQUIRE(isPermutation(r.order, n));
  double recomputed = 0.0;
  for (std::size_t i = 0; i + 1 < n; ++i) recomputed += real(r.order[i], r.order[i + 1]);
  CHECK(r.real_cost == Approx(recomputed).epsilon(1e-12));
  CHECK(std::isfinite(r.real_cost));
  CHECK(r.cost == bruteForce(scaled, 0));  // optimal at millisecond resolution
}

TEST_CASE("bad options and inputs throw naming the field", "[atsp][bad-input]") {
  const CostMatrix costs = randomCosts(5, 10, 1);
  AtspConfig options;
  options.time_limit_s = 0.0;
  CHECK_THROWS_WITH(solveAtsp(costs, options), Catch::Contains("time_limit_s"));
  options = {};
  options.exact_max_n = 19;
  CHECK_THROWS_WITH(options.validate(), Catch::Contains("exact_max_n"));
  options = {};
  options.cost_resolution = -1.0;
  CHECK_THROWS_WITH(options.validate(), Catch::Contains("cost_resolution"));
  options = {};
  options.open_from = 5;
  CHECK_THROWS_WITH(solveAtsp(costs, options), Catch::Contains("open_from"));
  options = {};
  CostMatrix negative = costs;
  negative(1, 2) = -kMaxArcCost - 1;
  CHECK_THROWS_WITH(solveAtsp(negative, options), Catch::Contains("cost(1, 2)"));
  RealCostMatrix with_nan(3, 1.0);
  with_nan(2, 0) = std::nan("");
  CHECK_THROWS_WITH(solveAtsp(with_nan, options), Catch::Contains("cost(2, 0)"));
  CHECK_THROWS_AS(tourCost(costs, {0, 1, 1, 2, 3}, true), std::invalid_argument);
}
