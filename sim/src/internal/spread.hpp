// Mean and sample standard deviation of benchmark figures (sim-internal).
#pragma once

#include <cmath>
#include <cstddef>
#include <vector>

namespace vdbmap::sim::internal {

struct Spread {
  double mean = 0.0, sd = 0.0;
  std::size_t n = 0;
};

inline Spread spread(const std::vector<double>& v) {
  Spread s;
  s.n = v.size();
  if (v.empty()) return s;
  for (double x : v) s.mean += x;
  s.mean /= double(v.size());
  if (v.size() > 1) {
    for (double x : v) s.sd += (x - s.mean) * (x - s.mean);
    s.sd = std::sqrt(s.sd / double(v.size() - 1));
  }
  return s;
}

}  // namespace vdbmap::sim::internal
