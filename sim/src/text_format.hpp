// Number formatting for the benchmarks' Markdown reports (sim-internal).
#pragma once

#include <cstdio>
#include <string>

namespace vdbmap::sim {

/// One number through a printf format, e.g. format("%.3f", x).
inline std::string format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, v);
  return buf;
}

}  // namespace vdbmap::sim
