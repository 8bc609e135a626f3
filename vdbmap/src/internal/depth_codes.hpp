// Depth codes of the keyframe store (private to the library): a depth in metres as a 16-bit count
// of `unit_m` steps, and the depth every decode gives back. Stored frames, and frames integrated
// in modes that store none, go through the same codes, so that every mode integrates the same depths.
#pragma once

#include "internal/simd.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace vdbmap::internal {

/// A depth's code: metres in `unit_m` steps, 0 for an invalid depth, clamped to [1, 65535] else.
inline std::uint16_t depthCode(float d, double unit_m) {
  if (!(d > 0.0f && std::isfinite(d))) return 0;
  return std::uint16_t(std::min(65535.0, std::max(1.0, double(d) / unit_m + 0.5)));
}

/// The depth every decode gives for a code.
inline float codeDepth(std::uint16_t q, double unit_m) { return q == 0 ? 0.0f : float(q * unit_m); }

/// depthCode() of depths[0, n) into codes. `level` says how many at a time; every level does
/// depthCode()'s operations lane by lane and gives the same codes.
void depthCodes(const float* depths, std::size_t n, double unit_m, std::uint16_t* codes, SimdLevel level = simdLevel());

/// codeDepth() of codes[0, n) into depths, at any level with the same result.
void codeDepths(const std::uint16_t* codes, std::size_t n, double unit_m, float* depths, SimdLevel level = simdLevel());

}  // namespace vdbmap::internal
