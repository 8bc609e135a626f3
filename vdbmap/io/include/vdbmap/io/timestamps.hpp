// Matching timestamps that name the same instant in different files.
#pragma once

#include <algorithm>
#include <cmath>

namespace vdbmap::io {

/// Two timestamps closer than this name the same frame (files hold 4 to 9 decimals; frames are
/// at least a few milliseconds apart).
constexpr double kTimestampMatchTolerance_s = 1e-4;

/// The first element of [first, last), sorted by ascending `timestamp_s`, whose stamp is within
/// `tolerance_s` of `t_s`; `last` when there is none.
template <typename It>
It findStamp(It first, It last, double t_s, double tolerance_s = kTimestampMatchTolerance_s) {
  const It it = std::lower_bound(first, last, t_s - tolerance_s,
                                 [](const auto& element, double t) { return element.timestamp_s < t; });
  return it != last && std::abs(it->timestamp_s - t_s) <= tolerance_s ? it : last;
}

}  // namespace vdbmap::io
