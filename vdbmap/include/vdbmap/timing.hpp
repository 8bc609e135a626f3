// Wall-clock timing of the library's own work (budgets, reports), on the steady clock, and the
// percentiles its reports give.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <vector>

namespace vdbmap {

/// Started on construction; ms() and s() read the time since then (or since the last restart()).
class Stopwatch {
 public:
  using Clock = std::chrono::steady_clock;

  Stopwatch() : start_(Clock::now()) {}
  void restart() { start_ = Clock::now(); }
  double ms() const { return std::chrono::duration<double, std::milli>(Clock::now() - start_).count(); }
  double s() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }
  Clock::time_point started() const { return start_; }

 private:
  Clock::time_point start_;
};

/// The q-quantile (q in [0, 1]) of `values` by nearest rank: the element at index
/// min(n - 1, floor(q n)) of the sorted values (q = 0.5 is the upper median). 0 when empty.
inline double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  const std::size_t n = values.size();
  const std::size_t k = std::min(n - 1, std::size_t(q * double(n)));
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(k), values.end());
  return values[k];
}

}  // namespace vdbmap
