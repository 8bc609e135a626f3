// Which vector instructions the library's pixel and voxel kernels use (private to the library).
//
// The library is built for the baseline x86-64 (SSE2). Kernels with a wider AVX2 path compile that
// path with a function target attribute, not a flag on the file, so that no inline function the
// rest of the library shares is built with instructions an older CPU lacks, and choose it at run
// time. AVX2 brings no FMA, so no product and sum is fused: every path gives the same bits. The AVX2
// level also takes the POPCNT instruction, which every CPU with AVX2 has.
#pragma once

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define VDBMAP_AVX2_KERNELS 1
#define VDBMAP_TARGET_AVX2 __attribute__((target("avx2,popcnt")))
#else
#define VDBMAP_AVX2_KERNELS 0
#define VDBMAP_TARGET_AVX2
#endif

namespace vdbmap::internal {

/// How many lanes a kernel may use: one value, SSE2's 128 bits or AVX2's 256.
enum class SimdLevel { Scalar = 0, Sse2 = 1, Avx2 = 2 };

/// The widest level this build has, this CPU runs and the current cap (ScopedSimdCap) allows.
SimdLevel simdLevel();

/// Caps simdLevel() process-wide while it lives, so that tests can run the narrower paths on a CPU
/// that has wider ones and compare them. Not for concurrent use with integration.
class ScopedSimdCap {
 public:
  explicit ScopedSimdCap(SimdLevel cap);
  ~ScopedSimdCap();
  ScopedSimdCap(const ScopedSimdCap&) = delete;
  ScopedSimdCap& operator=(const ScopedSimdCap&) = delete;

 private:
  int previous_;
};

}  // namespace vdbmap::internal
