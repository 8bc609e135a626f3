// Asymmetric travelling salesman: closed tours, and open paths from a fixed start (the
// exploration tour: start at the vehicle, visit every cluster, no return). A pure function over a
// dense cost matrix, time-bounded and deterministic for a seed.
//
// How it solves (see planner/src/atsp.cpp):
// - n <= AtspConfig::exact_max_n (default 16): Held-Karp dynamic programming, proven optimal
//   (a short local search runs first, so a time limit too short for the DP still gets a tour);
// - larger n: the assignment-problem lower bound (Hungarian method), Karp patching of its cycles
//   into a first tour, then iterated local search with orientation-preserving 3-opt moves
//   ("or3opt": segment swaps, Or-opt included) over reduced-cost candidate lists, kicked by
//   random local double bridges, until the time limit, or until the tour's cost meets the lower
//   bound (then optimality is proven; common on the tie-heavy rbg instances).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace vdbmap::planner {

/// A dense n x n matrix, row-major: `(from, to)` is the cost of the arc from -> to.
template <typename T>
class SquareMatrix {
 public:
  SquareMatrix() = default;
  explicit SquareMatrix(std::size_t n, T fill = T{}) : n_(n), values_(n * n, fill) {}

  std::size_t size() const { return n_; }
  T& operator()(std::size_t from, std::size_t to) { return values_[from * n_ + to]; }
  const T& operator()(std::size_t from, std::size_t to) const { return values_[from * n_ + to]; }
  const std::vector<T>& values() const { return values_; }

 private:
  std::size_t n_ = 0;
  std::vector<T> values_;
};

/// Integer arc costs (e.g. seconds scaled to milliseconds). The diagonal is ignored.
using CostMatrix = SquareMatrix<std::int64_t>;
/// Real arc costs (e.g. seconds); solved after rounding to multiples of `AtspConfig::cost_resolution`.
using RealCostMatrix = SquareMatrix<double>;

/// Largest arc cost the solver works with (2^44, about 1.8e13). Costs above it, and +infinity in a
/// RealCostMatrix, mean "unreachable": they are clamped to it, so sums never overflow and a tour
/// uses such an arc only when every tour must. Costs below -kMaxArcCost are rejected.
inline constexpr std::int64_t kMaxArcCost = std::int64_t{1} << 44;
/// Largest number of nodes (a dense matrix of this size already takes 32 GB).
inline constexpr std::size_t kMaxAtspNodes = std::size_t{1} << 16;

struct AtspConfig {
  /// Wall-clock budget in seconds, > 0. The search stops at this limit (or earlier, when the
  /// tour is proven optimal or max_iterations is reached).
  double time_limit_s = 1.0;
  /// Seed of the perturbations: the same seed, matrix and iteration count give the same tour.
  std::uint64_t seed = 1;
  /// Unset: a closed tour (returns to its first node). Set: an open path starting at this node
  /// that visits every node and does not return (the return arcs cost nothing).
  std::optional<std::size_t> open_from;
  /// Largest n solved exactly by Held-Karp dynamic programming, in [0, 18]. Its time grows as
  /// n^2 2^n: about 1 ms at n = 13, 10-20 ms at n = 16 on this machine.
  std::size_t exact_max_n = 16;
  /// Iterated local search rounds (perturbation + local search); 0 = no limit but the time.
  /// Setting it makes a run independent of machine speed (as long as the time limit is not hit).
  std::uint64_t max_iterations = 0;
  /// Rounds in a row without a cheaper tour after which the search stops, settled; 0 = never.
  /// Small instances find their best tour in the first few hundred rounds and would otherwise
  /// spend the rest of their time or iteration budget confirming it.
  std::uint64_t max_stale_iterations = 0;
  /// Only for RealCostMatrix: costs are solved as round(cost / cost_resolution), > 0.
  double cost_resolution = 1e-6;

  /// Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};
using AtspOptions [[deprecated("renamed AtspConfig")]] = AtspConfig;

enum class AtspStatus {
  kOptimal,         ///< proven optimal (exact DP, lower bound met, or n <= 3)
  kTimeLimit,       ///< best tour found when the time limit was reached
  kIterationLimit,  ///< best tour found after max_iterations rounds
  kSettled,         ///< best tour unchanged for max_stale_iterations rounds
};

std::string toString(AtspStatus status);

struct AtspResult {
  /// A permutation of 0..n-1: the visiting order. Open paths start with open_from; closed
  /// tours start with node 0 and return to it after the last node.
  std::vector<std::size_t> order;
  /// Sum of the arc costs along `order` (with the return arc for a closed tour), in the integer
  /// matrix's units, unreachable arcs counted as kMaxArcCost.
  std::int64_t cost = 0;
  /// For a RealCostMatrix: the cost recomputed from the real matrix (+inf if an arc is
  /// infinite). For a CostMatrix: equal to `cost`.
  double real_cost = 0.0;
  /// A proven lower bound on every tour's cost (the assignment bound or the exact optimum);
  /// std::numeric_limits<int64_t>::min() when none was computed (time ran out first).
  std::int64_t lower_bound = 0;
  bool optimal_proven = false;
  AtspStatus status = AtspStatus::kTimeLimit;
  double time_s = 0.0;           ///< total time spent
  double time_to_best_s = 0.0;   ///< when the returned tour was first found
  std::uint64_t iterations = 0;  ///< local-search rounds run
};

/// Solves the ATSP on integer costs. Throws std::invalid_argument for bad options, open_from
/// outside [0, n), n > kMaxAtspNodes, or a cost below -kMaxArcCost.
AtspResult solveAtsp(const CostMatrix& costs, const AtspConfig& options);

/// Solves the ATSP on real costs (rounded to options.cost_resolution; +inf and costs beyond
/// kMaxArcCost * cost_resolution are unreachable). Throws std::invalid_argument for NaN or
/// -inf costs, and as the integer overload.
AtspResult solveAtsp(const RealCostMatrix& costs, const AtspConfig& options);

/// Cost of visiting `order` (a closed tour when `closed`, else an open path), arcs clamped to
/// kMaxArcCost as the solver does. Throws std::invalid_argument if `order` is not a
/// permutation of 0..n-1.
std::int64_t tourCost(const CostMatrix& costs, const std::vector<std::size_t>& order, bool closed);

}  // namespace vdbmap::planner
