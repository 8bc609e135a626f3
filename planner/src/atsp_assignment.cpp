// The assignment relaxation of the ATSP and what is built from it: the lower bound, Karp's
// patching into a first tour, and reduced-cost candidate lists for the local search.
#include "atsp_internal.hpp"

#include <algorithm>
#include <limits>
#include <tuple>

namespace vdbmap::planner::atsp {
namespace {

// Larger than any reduced cost: costs are within 2^44 and potentials within n 2^45 (n <= 2^16).
constexpr std::int64_t kInfinity = std::numeric_limits<std::int64_t>::max() / 4;

}  // namespace

std::int64_t closedTourCost(const AtspInstance& instance, const std::vector<int>& order) {
  std::int64_t sum = 0;
  for (std::size_t i = 0; i < order.size(); ++i) sum += instance(order[i], order[(i + 1) % order.size()]);
  return sum;
}

// Rows are tails, columns heads (1-based inside, 0 is the virtual start column). Each row is
// added by a Dijkstra-like search for the cheapest augmenting path in reduced costs, which
// keeps the potentials dual-feasible. Diagonal arcs are simply never scanned.
std::optional<Assignment> solveAssignment(const AtspInstance& instance, const Deadline& deadline) {
  const int n = instance.n;
  std::vector<std::int64_t> u(std::size_t(n) + 1, 0), v(std::size_t(n) + 1, 0), min_slack(std::size_t(n) + 1);
  std::vector<int> row_of_col(std::size_t(n) + 1, 0), previous_col(std::size_t(n) + 1, 0);
  std::vector<char> visited(std::size_t(n) + 1);
  for (int row = 1; row <= n; ++row) {
    if (deadline.passed()) return std::nullopt;
    row_of_col[0] = row;
    int col = 0;
    std::fill(min_slack.begin(), min_slack.end(), kInfinity);
    std::fill(visited.begin(), visited.end(), 0);
    do {
      visited[std::size_t(col)] = 1;
      const int r = row_of_col[std::size_t(col)];
      const std::int64_t* cost_row = &instance.costs[std::size_t(r - 1) * std::size_t(n)];
      std::int64_t delta = kInfinity;
      int next_col = 0;
      for (int j = 1; j <= n; ++j) {
        if (visited[std::size_t(j)]) continue;
        if (j != r) {
          const std::int64_t slack = cost_row[j - 1] - u[std::size_t(r)] - v[std::size_t(j)];
          if (slack < min_slack[std::size_t(j)]) {
            min_slack[std::size_t(j)] = slack;
            previous_col[std::size_t(j)] = col;
          }
        }
        if (min_slack[std::size_t(j)] < delta) {
          delta = min_slack[std::size_t(j)];
          next_col = j;
        }
      }
      for (int j = 0; j <= n; ++j) {
        if (visited[std::size_t(j)]) {
          u[std::size_t(row_of_col[std::size_t(j)])] += delta;
          v[std::size_t(j)] -= delta;
        } else {
          min_slack[std::size_t(j)] -= delta;
        }
      }
      col = next_col;
    } while (row_of_col[std::size_t(col)] != 0);
    do {  // flip the augmenting path
      const int prev = previous_col[std::size_t(col)];
      row_of_col[std::size_t(col)] = row_of_col[std::size_t(prev)];
      col = prev;
    } while (col != 0);
  }
  Assignment result;
  result.successor.assign(std::size_t(n), -1);
  result.row_potential.resize(std::size_t(n));
  result.col_potential.resize(std::size_t(n));
  for (int j = 1; j <= n; ++j) result.successor[std::size_t(row_of_col[std::size_t(j)] - 1)] = j - 1;
  for (int i = 0; i < n; ++i) {
    result.row_potential[std::size_t(i)] = u[std::size_t(i) + 1];
    result.col_potential[std::size_t(i)] = v[std::size_t(i) + 1];
    result.cost += instance(i, result.successor[std::size_t(i)]);
  }
  return result;
}

std::vector<int> patchSubtours(const AtspInstance& instance, std::vector<int> successor, const Deadline& deadline) {
  const int n = instance.n;
  std::vector<int> cycle_of(std::size_t(n), -1);
  std::vector<std::vector<int>> cycles;
  for (int start = 0; start < n; ++start) {
    if (cycle_of[std::size_t(start)] >= 0) continue;
    cycles.emplace_back();
    for (int i = start; cycle_of[std::size_t(i)] < 0; i = successor[std::size_t(i)]) {
      cycle_of[std::size_t(i)] = int(cycles.size()) - 1;
      cycles.back().push_back(i);
    }
  }
  // Grow the largest subtour: each step exchanges the successors of one of its nodes i and one
  // outside node j (i -> s(j), j -> s(i)), which splices j's subtour in, at the least extra cost.
  const auto largest =
      std::max_element(cycles.begin(), cycles.end(), [](const auto& a, const auto& b) { return a.size() < b.size(); });
  const int main_cycle = int(largest - cycles.begin());
  std::vector<int> members = cycles[std::size_t(main_cycle)];
  for (std::size_t merged = 1; merged < cycles.size(); ++merged) {
    std::int64_t best_delta = std::numeric_limits<std::int64_t>::max();
    int best_i = -1, best_j = -1;
    const bool out_of_time = deadline.passed();
    for (const int i : members) {
      if (out_of_time && best_i >= 0) break;  // any exchange still merges: take the first one
      const int si = successor[std::size_t(i)];
      for (int j = 0; j < n; ++j) {
        if (cycle_of[std::size_t(j)] == main_cycle) continue;
        const int sj = successor[std::size_t(j)];
        const std::int64_t delta = instance(i, sj) + instance(j, si) - instance(i, si) - instance(j, sj);
        if (delta < best_delta) {
          best_delta = delta;
          best_i = i;
          best_j = j;
        }
      }
    }
    const int absorbed = cycle_of[std::size_t(best_j)];
    for (const int j : cycles[std::size_t(absorbed)]) {
      cycle_of[std::size_t(j)] = main_cycle;
      members.push_back(j);
    }
    std::swap(successor[std::size_t(best_i)], successor[std::size_t(best_j)]);
  }
  std::vector<int> order;
  order.reserve(std::size_t(n));
  for (int i = 0, k = 0; k < n; ++k, i = successor[std::size_t(i)]) order.push_back(i);
  return order;
}

std::vector<int> nearestNeighbourTour(const AtspInstance& instance, const Deadline& deadline) {
  const int n = instance.n;
  std::vector<char> used(std::size_t(n), 0);
  std::vector<int> order{0};
  used[0] = 1;
  while (int(order.size()) < n) {
    const int from = order.back();
    const bool out_of_time = (order.size() & 63) == 0 && deadline.passed();
    int best = -1;
    for (int j = 0; j < n; ++j) {
      if (used[std::size_t(j)]) continue;
      if (best < 0 || instance(from, j) < instance(from, best)) best = j;
      if (out_of_time) break;  // the rest in index order, so the caller still gets a tour
    }
    used[std::size_t(best)] = 1;
    order.push_back(best);
  }
  return order;
}

std::optional<CandidateLists> buildCandidates(const AtspInstance& instance, const Assignment* assignment, int k,
                                              const Deadline& deadline) {
  const int n = instance.n;
  CandidateLists lists;
  lists.k = std::min(k, n - 1);
  lists.out.resize(std::size_t(n) * std::size_t(lists.k));
  lists.in.resize(std::size_t(n) * std::size_t(lists.k));
  // Rank by (reduced cost, cost, node) so that ties, which are everywhere on some instances,
  // break the same way on every machine.
  const auto key = [&](int from, int to) {
    const std::int64_t reduced = assignment ? assignment->reducedCost(instance, from, to) : instance(from, to);
    return std::make_tuple(reduced, instance(from, to));
  };
  std::vector<int> others(std::size_t(n) - 1);
  for (int node = 0; node < n; ++node) {
    if ((node & 15) == 0 && deadline.passed()) return std::nullopt;
    for (int dir = 0; dir < 2; ++dir) {
      std::size_t m = 0;
      for (int j = 0; j < n; ++j)
        if (j != node) others[m++] = j;
      const auto less = [&](int a, int b) {
        const auto ka = dir == 0 ? key(node, a) : key(a, node);
        const auto kb = dir == 0 ? key(node, b) : key(b, node);
        return ka < kb || (ka == kb && a < b);
      };
      std::partial_sort(others.begin(), others.begin() + lists.k, others.end(), less);
      int* dst = &(dir == 0 ? lists.out : lists.in)[std::size_t(node) * std::size_t(lists.k)];
      std::copy(others.begin(), others.begin() + lists.k, dst);
    }
  }
  return lists;
}

}  // namespace vdbmap::planner::atsp
