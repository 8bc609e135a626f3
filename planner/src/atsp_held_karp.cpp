// Held-Karp dynamic programming: best[S][j] = cheapest path from node 0 through exactly the
// nodes of S (a subset of 1..n-1) ending at j in S. Subsets are visited in increasing order, so
// S \ {j} is always done before S.
#include "atsp_internal.hpp"

#include <limits>

namespace vdbmap::planner::atsp {

std::optional<std::vector<int>> heldKarpTour(const AtspInstance& instance, const Deadline& deadline) {
  const int n = instance.n;
  const int m = n - 1;  // nodes 1..n-1 are bits 0..m-1
  const std::size_t subsets = std::size_t{1} << m;
  constexpr std::int64_t kUnset = std::numeric_limits<std::int64_t>::max();
  // A local copy of the arcs between the other nodes: small and contiguous for the inner loop.
  std::vector<std::int64_t> arc(std::size_t(m) * std::size_t(m));
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) arc[std::size_t(a) * std::size_t(m) + std::size_t(b)] = instance(a + 1, b + 1);

  std::vector<std::int64_t> best(subsets * std::size_t(m), kUnset);
  for (int j = 0; j < m; ++j) best[(std::size_t{1} << j) * std::size_t(m) + std::size_t(j)] = instance(0, j + 1);
  for (std::size_t set = 1; set < subsets; ++set) {
    if ((set & 0xfff) == 0 && deadline.passed()) return std::nullopt;
    if ((set & (set - 1)) == 0) continue;  // single nodes are initialised above
    std::int64_t* row = &best[set * std::size_t(m)];
    for (std::size_t rest_j = set; rest_j; rest_j &= rest_j - 1) {
      const int j = __builtin_ctzll(rest_j);
      const std::size_t prev = set ^ (std::size_t{1} << j);
      const std::int64_t* prev_row = &best[prev * std::size_t(m)];
      std::int64_t value = kUnset;
      for (std::size_t rest_k = prev; rest_k; rest_k &= rest_k - 1) {
        const int k = __builtin_ctzll(rest_k);
        const std::int64_t candidate = prev_row[k] + arc[std::size_t(k) * std::size_t(m) + std::size_t(j)];
        if (candidate < value) value = candidate;
      }
      row[j] = value;
    }
  }

  // Close the tour, then walk back through the table: the predecessor of j in S is any k whose
  // value plus the arc k -> j reproduces best[S][j]; the smallest such k keeps it deterministic.
  const std::size_t full = subsets - 1;
  int last = 0;
  std::int64_t tour_cost = kUnset;
  for (int j = 0; j < m; ++j) {
    const std::int64_t candidate = best[full * std::size_t(m) + std::size_t(j)] + instance(j + 1, 0);
    if (candidate < tour_cost) {
      tour_cost = candidate;
      last = j;
    }
  }
  std::vector<int> order(std::size_t(n), 0);
  std::size_t set = full;
  for (int position = n - 1; position >= 1; --position) {
    order[std::size_t(position)] = last + 1;
    const std::size_t prev = set ^ (std::size_t{1} << last);
    if (prev == 0) break;
    const std::int64_t target = best[set * std::size_t(m) + std::size_t(last)];
    for (std::size_t rest_k = prev; rest_k; rest_k &= rest_k - 1) {
      const int k = __builtin_ctzll(rest_k);
      if (best[prev * std::size_t(m) + std::size_t(k)] + arc[std::size_t(k) * std::size_t(m) + std::size_t(last)] ==
          target) {
        last = k;
        break;
      }
    }
    set = prev;
  }
  return order;
}

}  // namespace vdbmap::planner::atsp
