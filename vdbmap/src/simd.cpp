#include "internal/simd.hpp"

#include <algorithm>
#include <atomic>

namespace vdbmap::internal {
namespace {

SimdLevel cpuLevel() {
#if VDBMAP_AVX2_KERNELS
  __builtin_cpu_init();  // in case this runs before libgcc's own initialisation (a static constructor)
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("popcnt")) return SimdLevel::Avx2;
#endif
#if defined(__SSE2__)
  return SimdLevel::Sse2;
#else
  return SimdLevel::Scalar;
#endif
}

std::atomic<int> g_cap{int(SimdLevel::Avx2)};

}  // namespace

SimdLevel simdLevel() {
  static const SimdLevel cpu = cpuLevel();
  return SimdLevel(std::min(int(cpu), g_cap.load(std::memory_order_relaxed)));
}

ScopedSimdCap::ScopedSimdCap(SimdLevel cap) : previous_(g_cap.exchange(int(cap))) {}
ScopedSimdCap::~ScopedSimdCap() { g_cap.store(previous_); }

}  // namespace vdbmap::internal
