#include "internal/depth_codes.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if VDBMAP_AVX2_KERNELS
#include <immintrin.h>
#endif

#include <limits>

namespace vdbmap::internal {
namespace {

#if VDBMAP_AVX2_KERNELS
/// depthCodes four at a time; returns how many it coded (a multiple of four).
VDBMAP_TARGET_AVX2 std::size_t depthCodesAvx2(const float* depths, std::size_t n, double unit_m, std::uint16_t* codes) {
  const __m256d unit = _mm256_set1_pd(unit_m), half = _mm256_set1_pd(0.5), one = _mm256_set1_pd(1.0);
  const __m256d top = _mm256_set1_pd(65535.0), zero = _mm256_setzero_pd();
  const __m256d largest = _mm256_set1_pd(double(std::numeric_limits<float>::max()));
  std::size_t i = 0;
  for (; i + 3 < n; i += 4) {
    const __m256d d = _mm256_cvtps_pd(_mm_loadu_ps(depths + i));
    // max(x, 1) and min(x, 65535) take the constant for NaN, as std::max(1.0, x) and std::min do.
    const __m256d clamped = _mm256_min_pd(_mm256_max_pd(_mm256_add_pd(_mm256_div_pd(d, unit), half), one), top);
    const __m256d valid = _mm256_and_pd(_mm256_cmp_pd(d, zero, _CMP_GT_OQ), _mm256_cmp_pd(d, largest, _CMP_LE_OQ));
    // Truncated to int32 (values in [1, 65535]); invalid lanes 0 (the low halves of the 64-bit
    // mask lanes mask them); packed to 16 bits.
    const __m256i mask =
        _mm256_permutevar8x32_epi32(_mm256_castpd_si256(valid), _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6));
    const __m128i q = _mm_and_si128(_mm256_cvttpd_epi32(clamped), _mm256_castsi256_si128(mask));
    _mm_storel_epi64(reinterpret_cast<__m128i*>(codes + i), _mm_packus_epi32(q, q));
  }
  return i;
}

/// codeDepths four at a time; returns how many it decoded (a multiple of four).
VDBMAP_TARGET_AVX2 std::size_t codeDepthsAvx2(const std::uint16_t* codes, std::size_t n, double unit_m, float* depths) {
  const __m256d unit = _mm256_set1_pd(unit_m);
  std::size_t i = 0;
  for (; i + 3 < n; i += 4) {
    const __m128i q = _mm_cvtepu16_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(codes + i)));
    // Code 0 gives 0 * unit_m = +0.0f, codeDepth's value for it (unit_m > 0).
    _mm_storeu_ps(depths + i, _mm256_cvtpd_ps(_mm256_mul_pd(_mm256_cvtepi32_pd(q), unit)));
  }
  return i;
}
#endif

}  // namespace

void depthCodes(const float* depths, std::size_t n, double unit_m, std::uint16_t* codes, SimdLevel level) {
  std::size_t i = 0;
#if VDBMAP_AVX2_KERNELS
  if (level == SimdLevel::Avx2) i = depthCodesAvx2(depths, n, unit_m, codes);
#endif
#if defined(__SSE2__)
  if (level != SimdLevel::Scalar) {
    const __m128d unit = _mm_set1_pd(unit_m), half = _mm_set1_pd(0.5), one = _mm_set1_pd(1.0);
    const __m128d top = _mm_set1_pd(65535.0), zero = _mm_setzero_pd();
    const __m128d largest = _mm_set1_pd(double(std::numeric_limits<float>::max()));
    for (; i + 1 < n; i += 2) {
      const __m128d d = _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(depths + i))));
      const __m128d clamped = _mm_min_pd(_mm_max_pd(_mm_add_pd(_mm_div_pd(d, unit), half), one), top);
      const int valid = _mm_movemask_pd(_mm_and_pd(_mm_cmpgt_pd(d, zero), _mm_cmple_pd(d, largest)));
      alignas(16) std::int32_t q[4];
      _mm_store_si128(reinterpret_cast<__m128i*>(q), _mm_cvttpd_epi32(clamped));
      codes[i] = (valid & 1) ? std::uint16_t(q[0]) : std::uint16_t(0);
      codes[i + 1] = (valid & 2) ? std::uint16_t(q[1]) : std::uint16_t(0);
    }
  }
#endif
  (void)level;
  for (; i < n; ++i) codes[i] = depthCode(depths[i], unit_m);
}

void codeDepths(const std::uint16_t* codes, std::size_t n, double unit_m, float* depths, SimdLevel level) {
  std::size_t i = 0;
#if VDBMAP_AVX2_KERNELS
  if (level == SimdLevel::Avx2) i = codeDepthsAvx2(codes, n, unit_m, depths);
#endif
  (void)level;
  for (; i < n; ++i) depths[i] = codeDepth(codes[i], unit_m);
}

}  // namespace vdbmap::internal
