// Private building blocks of the ATSP solver (planner/src/atsp*.cpp). Every piece works on a
// closed tour over an `AtspInstance`; open paths are turned into closed tours before (the arcs
// back to the start cost nothing).
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <optional>
#include <vector>

namespace vdbmap::planner::atsp {

using Clock = std::chrono::steady_clock;

/// The stop time of a solve. `passed()` is the only wall-clock decision the solver makes.
class Deadline {
 public:
  /// Limits beyond 10^9 s (31 years) are cut there, so the end time cannot overflow.
  Deadline(Clock::time_point start, double limit_s)
      : start_(start),
        end_(start +
             std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::min(limit_s, 1e9)))) {}
  bool passed() const { return Clock::now() >= end_; }
  double elapsedS() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }

 private:
  Clock::time_point start_, end_;
};

/// A closed ATSP instance: costs clamped to [-kMaxArcCost, kMaxArcCost], diagonal unused.
struct AtspInstance {
  int n = 0;
  std::vector<std::int64_t> costs;  // row-major n x n
  std::int64_t operator()(int from, int to) const {
    return costs[std::size_t(from) * std::size_t(n) + std::size_t(to)];
  }
};

/// Cost of the closed tour visiting `order`.
std::int64_t closedTourCost(const AtspInstance& instance, const std::vector<int>& order);

/// Optimal assignment (a successor for every node, no node its own successor) with the dual
/// potentials of the Hungarian method: reduced costs c(i, j) - row[i] - col[j] are >= 0 and
/// 0 on the assignment; its cost is a lower bound on every tour.
struct Assignment {
  std::vector<int> successor;
  std::vector<std::int64_t> row_potential, col_potential;
  std::int64_t cost = 0;
  std::int64_t reducedCost(const AtspInstance& instance, int from, int to) const {
    return instance(from, to) - row_potential[std::size_t(from)] - col_potential[std::size_t(to)];
  }
};

/// The Hungarian method (shortest augmenting paths, O(n^3)); nullopt if the deadline passes first. n >= 2.
std::optional<Assignment> solveAssignment(const AtspInstance& instance, const Deadline& deadline);

/// Karp's patching: merges the assignment's subtours one at a time into the largest, each time by
/// the cheapest exchange of two successors, and returns the resulting tour as a visiting order.
/// Once the deadline has passed, the remaining subtours are merged by the first exchange found.
std::vector<int> patchSubtours(const AtspInstance& instance, std::vector<int> successor, const Deadline& deadline);

/// Nearest-neighbour tour from node 0 (the fallback when the assignment did not finish). Once
/// the deadline has passed, the remaining nodes follow in index order.
std::vector<int> nearestNeighbourTour(const AtspInstance& instance, const Deadline& deadline);

/// Held-Karp dynamic programming: an optimal closed tour starting at node 0; nullopt if the
/// deadline passes first. Time and memory grow as n^2 2^n and n 2^n; n in [2, 20].
std::optional<std::vector<int>> heldKarpTour(const AtspInstance& instance, const Deadline& deadline);

/// Candidate arcs of the local search: for every node its `k` best successors and `k` best
/// predecessors, ranked by the assignment's reduced cost when there is one (an excellent
/// predictor of optimal-tour arcs on asymmetric instances), by cost otherwise.
struct CandidateLists {
  int k = 0;
  std::vector<int> out, in;  // n x k, row-major
};
/// nullopt if the deadline passes first.
std::optional<CandidateLists> buildCandidates(const AtspInstance& instance, const Assignment* assignment, int k,
                                              const Deadline& deadline);

struct IlsSettings {
  std::uint64_t seed = 1;
  std::uint64_t max_iterations = 0;  // 0 = until the deadline or the bound
  std::uint64_t max_stale_iterations = 0;  // rounds in a row without a better tour; 0 = no limit
  /// Stop as soon as the tour costs this much (a proven lower bound); nullopt = never.
  std::optional<std::int64_t> lower_bound;
};

struct IlsOutcome {
  std::vector<int> order;
  std::int64_t cost = 0;
  std::uint64_t iterations = 0;
  double time_to_best_s = 0.0;  // as Deadline::elapsedS()
  bool reached_bound = false;
  bool reached_max_iterations = false;
  bool settled = false;  // stopped after max_stale_iterations rounds without a better tour
};

/// Iterated local search from `initial` (a closed tour, n >= 4): orientation-preserving 3-opt
/// descent with don't-look bits, random local double-bridge kicks, better-or-equal acceptance.
IlsOutcome iteratedLocalSearch(const AtspInstance& instance, const CandidateLists& candidates,
                               const std::vector<int>& initial, const IlsSettings& settings, const Deadline& deadline);

}  // namespace vdbmap::planner::atsp
