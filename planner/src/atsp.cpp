// The ATSP entry points: input checks, the open-path transform, and the choice between the
// exact DP and the iterated local search (see atsp.hpp for the overview).
#include "vdbmap/planner/atsp.hpp"

#include "atsp_internal.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace vdbmap::planner {

using atsp::AtspInstance;
using atsp::Deadline;

namespace {

// Candidate successors and predecessors per node in the local search.
constexpr int kCandidates = 10;
// Local-search rounds before the exact DP: they give a tour should the DP run out of time.
constexpr std::uint64_t kRoundsBeforeExactPerNode = 8;

std::int64_t clampArc(std::int64_t cost, std::size_t from, std::size_t to) {
  if (cost < -kMaxArcCost)
    throw std::invalid_argument("solveAtsp: cost(" + std::to_string(from) + ", " + std::to_string(to) +
                                ") = " + std::to_string(cost) + " is below -kMaxArcCost (-2^44)");
  return std::min(cost, kMaxArcCost);
}

/// The closed instance solved: clamped costs; for an open path from s every arc into s costs 0,
/// so the best closed tour, cut before s, is the best path from s.
AtspInstance makeInstance(const CostMatrix& costs, const std::optional<std::size_t>& open_from) {
  const std::size_t n = costs.size();
  AtspInstance instance;
  instance.n = int(n);
  instance.costs.resize(n * n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j)
      instance.costs[i * n + j] = i == j ? 0 : (open_from && j == *open_from ? 0 : clampArc(costs(i, j), i, j));
  return instance;
}

/// Every closed tour of at most 3 nodes: at most two directions to compare.
std::vector<int> tinyOptimalTour(const AtspInstance& instance) {
  std::vector<int> order(std::size_t(instance.n));
  for (int i = 0; i < instance.n; ++i) order[std::size_t(i)] = i;
  if (instance.n == 3 && atsp::closedTourCost(instance, {0, 2, 1}) < atsp::closedTourCost(instance, order))
    order = {0, 2, 1};
  return order;
}

std::vector<std::size_t> rotateToStart(const std::vector<int>& order, int start) {
  const auto it = std::find(order.begin(), order.end(), start);
  std::vector<std::size_t> rotated;
  rotated.reserve(order.size());
  for (auto i = it; i != order.end(); ++i) rotated.push_back(std::size_t(*i));
  for (auto i = order.begin(); i != it; ++i) rotated.push_back(std::size_t(*i));
  return rotated;
}

struct Search {
  std::vector<int> order;
  std::int64_t lower_bound = std::numeric_limits<std::int64_t>::min();
  bool optimal = false;
  bool iteration_limit = false;
  bool settled = false;
  double time_to_best_s = 0.0;
  std::uint64_t iterations = 0;
};

Search solveInstance(const AtspInstance& instance, const AtspConfig& options, const Deadline& deadline) {
  Search search;
  if (instance.n <= 3) {
    search.order = tinyOptimalTour(instance);
    search.lower_bound = atsp::closedTourCost(instance, search.order);
    search.optimal = true;
    return search;
  }
  const std::optional<atsp::Assignment> assignment = atsp::solveAssignment(instance, deadline);
  std::vector<int> initial;
  if (assignment) {
    search.lower_bound = assignment->cost;
    initial = atsp::patchSubtours(instance, assignment->successor, deadline);
  } else {
    initial = atsp::nearestNeighbourTour(instance, deadline);
  }
  const std::optional<atsp::CandidateLists> candidates =
      atsp::buildCandidates(instance, assignment ? &*assignment : nullptr, kCandidates, deadline);
  if (!candidates) {  // out of time before the local search could start
    search.order = initial;
    search.optimal = assignment && atsp::closedTourCost(instance, initial) == assignment->cost;
    search.time_to_best_s = deadline.elapsedS();
    return search;
  }

  const bool exact = std::size_t(instance.n) <= options.exact_max_n;
  atsp::IlsSettings settings;
  settings.seed = options.seed;
  settings.max_iterations = options.max_iterations;
  settings.max_stale_iterations = options.max_stale_iterations;
  if (exact) {
    const std::uint64_t rounds = kRoundsBeforeExactPerNode * std::uint64_t(instance.n);
    settings.max_iterations = settings.max_iterations == 0 ? rounds : std::min(settings.max_iterations, rounds);
  }
  if (assignment) settings.lower_bound = assignment->cost;
  const atsp::IlsOutcome ils = atsp::iteratedLocalSearch(instance, *candidates, initial, settings, deadline);
  search.order = ils.order;
  search.time_to_best_s = ils.time_to_best_s;
  search.iterations = ils.iterations;
  search.optimal = ils.reached_bound;
  search.iteration_limit = ils.reached_max_iterations;
  search.settled = ils.settled;

  if (exact && !search.optimal) {
    if (const auto optimal = atsp::heldKarpTour(instance, deadline)) {
      if (atsp::closedTourCost(instance, *optimal) < ils.cost) search.time_to_best_s = deadline.elapsedS();
      search.order = *optimal;
      search.lower_bound = atsp::closedTourCost(instance, *optimal);
      search.optimal = true;
    } else {
      search.iteration_limit = search.settled = false;  // the DP ran out of time: that is why the search stopped
    }
  }
  return search;
}

}  // namespace

std::string toString(AtspStatus status) {
  switch (status) {
    case AtspStatus::kOptimal:
      return "optimal";
    case AtspStatus::kTimeLimit:
      return "time_limit";
    case AtspStatus::kIterationLimit:
      return "iteration_limit";
    case AtspStatus::kSettled: return "settled";
  }
  return "unknown";
}

void AtspConfig::validate() const {
  if (!(time_limit_s > 0.0) || !std::isfinite(time_limit_s))
    throw std::invalid_argument("AtspConfig::time_limit_s must be finite and > 0, got " +
                                std::to_string(time_limit_s));
  if (exact_max_n > 18)
    throw std::invalid_argument("AtspConfig::exact_max_n must be in [0, 18], got " + std::to_string(exact_max_n));
  if (!(cost_resolution > 0.0) || !std::isfinite(cost_resolution))
    throw std::invalid_argument("AtspConfig::cost_resolution must be finite and > 0, got " +
                                std::to_string(cost_resolution));
}

std::int64_t tourCost(const CostMatrix& costs, const std::vector<std::size_t>& order, bool closed) {
  const std::size_t n = costs.size();
  std::vector<char> seen(n, 0);
  for (const std::size_t node : order) {
    if (node >= n || seen[node]) throw std::invalid_argument("tourCost: order is not a permutation of 0..n-1");
    seen[node] = 1;
  }
  if (order.size() != n) throw std::invalid_argument("tourCost: order is not a permutation of 0..n-1");
  std::int64_t sum = 0;
  for (std::size_t i = 0; i + 1 < n; ++i) sum += std::min(costs(order[i], order[i + 1]), kMaxArcCost);
  if (closed && n > 1) sum += std::min(costs(order[n - 1], order[0]), kMaxArcCost);
  return sum;
}

AtspResult solveAtsp(const CostMatrix& costs, const AtspConfig& options) {
  const auto start = atsp::Clock::now();
  options.validate();
  const std::size_t n = costs.size();
  if (n > kMaxAtspNodes)
    throw std::invalid_argument("solveAtsp: n = " + std::to_string(n) + " exceeds kMaxAtspNodes = 65536");
  if (options.open_from && *options.open_from >= n)
    throw std::invalid_argument("AtspConfig::open_from must be in [0, " + std::to_string(n) + "), got " +
                                std::to_string(*options.open_from));
  const Deadline deadline(start, options.time_limit_s);
  AtspResult result;
  if (n == 0) {
    result.status = AtspStatus::kOptimal;
    result.optimal_proven = true;
    return result;
  }
  const AtspInstance instance = makeInstance(costs, options.open_from);
  const Search search = solveInstance(instance, options, deadline);
  result.order = rotateToStart(search.order, options.open_from ? int(*options.open_from) : 0);
  result.cost = tourCost(costs, result.order, !options.open_from);
  result.real_cost = double(result.cost);
  result.lower_bound = search.lower_bound;
  result.optimal_proven = search.optimal;
  result.status = search.optimal           ? AtspStatus::kOptimal
                  : search.iteration_limit ? AtspStatus::kIterationLimit
                  : search.settled         ? AtspStatus::kSettled
                                           : AtspStatus::kTimeLimit;
  result.iterations = search.iterations;
  result.time_to_best_s = search.time_to_best_s;
  result.time_s = deadline.elapsedS();
  return result;
}

AtspResult solveAtsp(const RealCostMatrix& costs, const AtspConfig& options) {
  options.validate();
  const std::size_t n = costs.size();
  CostMatrix quantized(n);
  const double max_real = double(kMaxArcCost) * options.cost_resolution;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < n; ++j) {
      const double c = costs(i, j);
      if (i == j) continue;
      if (std::isnan(c) || c <= -max_real)
        throw std::invalid_argument("solveAtsp: cost(" + std::to_string(i) + ", " + std::to_string(j) + ") is " +
                                    std::to_string(c) +
                                    "; costs must be numbers above -2^44 * cost_resolution, or +inf");
      quantized(i, j) = c >= max_real ? kMaxArcCost : std::llround(c / options.cost_resolution);
    }
  }
  AtspResult result = solveAtsp(quantized, options);
  result.real_cost = 0.0;
  for (std::size_t i = 0; i + 1 < n; ++i) result.real_cost += costs(result.order[i], result.order[i + 1]);
  if (!options.open_from && n > 1) result.real_cost += costs(result.order[n - 1], result.order[0]);
  return result;
}

}  // namespace vdbmap::planner
