// Classifying a depth image's pixels for projective integration (private to the library):
// what each pixel's depth makes of its ray, two pixels at a time on x86-64 and four with AVX2
// (internal/simd.hpp). The wider paths do exactly the one-pixel path's arithmetic lane by lane, so
// the map does not depend on them.
#pragma once

#include "internal/simd.hpp"
#include "internal/voxel_blocks.hpp"

#include "vdbmap/config.hpp"
#include "vdbmap/voxel_codec.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

// x86-64's SSE2 has the 64-bit conversions the weights need.
#if defined(__SSE2__) && defined(__x86_64__)
#define VDBMAP_PIXEL_PAIRS 1
#include <emmintrin.h>
#if VDBMAP_AVX2_KERNELS
#include <immintrin.h>
#endif
#else
#define VDBMAP_PIXEL_PAIRS 0
#endif

namespace vdbmap::internal {

/// What each pixel contributes: the range of its surface along its ray (or max range for pixels
/// beyond it, which only carve free space) and its fixed-point weight (0: invalid pixel). One
/// 24-byte record per pixel (the weight needs 64 bits: it grows as 1 / z^2).
struct PixelRay {
  std::int64_t weight_q = 0;
  float range_m = 0.0f;
  /// A voxel at distance d on this ray is free space when d^2 <= free2 (sdf >= truncation), and in
  /// the band when free2 < d^2 <= band2 (band2 = free2 for a pixel beyond max range, which adds no
  /// surface); squared, so most voxels need no square root.
  float free2 = -1.0f;
  float band2 = -1.0f;
};

/// Pixels per side of the tiles whose largest range culls leaves.
inline constexpr int kPixelTile = 8;

/// What a pixel's depth makes of its ray (PixelRay), and the counts and maxima over a row.
class PixelClassifier {
 public:
  PixelClassifier(const TsdfConfig& tsdf, const IntegratorConfig& in)
      : min_r_(in.min_range_m),
        max_r_(in.max_range_m),
        delta_(tsdf.truncation_m()),
        scale_(weightScaleFor(tsdf, in)),
        constant_(tsdf.weighting == Weighting::Constant) {}

  /// Counts and largest range over the pixels classified so far.
  struct Tally {
    std::size_t invalid = 0, beyond = 0;
    double max_range_m = 0.0;
  };

  /// Classifies pixels [0, width) of one row: depths z_row, ray norms norm_row (|ray| per unit
  /// depth), records into rays; each valid range raises tile_max[u / kPixelTile]. `level` says how
  /// many pixels at a time; every level gives the same records.
  void row(const float* z_row, const float* norm_row, int width, PixelRay* rays, float* tile_max, Tally& tally,
           SimdLevel level = simdLevel()) const {
    int u = 0;
#if VDBMAP_PIXEL_PAIRS
#if VDBMAP_AVX2_KERNELS
    static_assert(kPixelTile % 4 == 0, "four pixels at a time stay in one tile");
    if (level == SimdLevel::Avx2)
      for (; u + 3 < width; u += 4) quad(z_row + u, norm_row + u, rays + u, tile_max[u / kPixelTile], tally);
#endif
    if (level != SimdLevel::Scalar)
      for (; u + 1 < width; u += 2) pair(z_row + u, norm_row + u, rays + u, tile_max[u / kPixelTile], tally);
#else
    (void)level;
#endif
    for (; u < width; ++u) {
      rays[u] = pixel(z_row[u], norm_row[u], tally);
      if (rays[u].weight_q != 0) tile_max[u / kPixelTile] = std::max(tile_max[u / kPixelTile], rays[u].range_m);
    }
  }

  /// One pixel: invalid (counted) for a depth that is not finite and positive, a range below
  /// min_range_m or a weight that rounds to 0; beyond max_range_m it only carves free space. The
  /// reference that row()'s pairs repeat.
  PixelRay pixel(float z_f, float norm, Tally& tally) const {
    const double z = z_f;
    const double range = z * double(norm);
    if (!(z > 0.0) || !std::isfinite(z) || range < min_r_) {
      ++tally.invalid;
      return PixelRay{};
    }
    const bool beyond_range = range > max_r_;
    const double r_m = beyond_range ? max_r_ : range;
    const double z_eff = beyond_range ? z * max_r_ / range : z;
    const std::int64_t weight_q = constant_ ? scale_ : roundToInt64(double(scale_) / (z_eff * z_eff));
    if (weight_q == 0) {  // only with a weight scale too small for the range: counted, not lost silently
      ++tally.invalid;
      return PixelRay{};
    }
    if (beyond_range) ++tally.beyond;
    PixelRay ray;
    ray.range_m = float(r_m);
    ray.free2 = r_m >= delta_ ? float((r_m - delta_) * (r_m - delta_)) : -1.0f;
    ray.band2 = beyond_range ? ray.free2 : float((r_m + delta_) * (r_m + delta_));
    ray.weight_q = weight_q;
    tally.max_range_m = std::max(tally.max_range_m, double(ray.range_m));
    return ray;
  }

 private:
#if VDBMAP_PIXEL_PAIRS
  static __m128d select(__m128d mask, __m128d a, __m128d b) {
    return _mm_or_pd(_mm_and_pd(mask, a), _mm_andnot_pd(mask, b));
  }
  static __m128d loadTwo(const float* p) {
    return _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p))));
  }
  /// Pixels u and u + 1 in lanes 0 and 1, each lane doing exactly pixel()'s arithmetic (the
  /// selects pick what pixel()'s branches would compute).
  void pair(const float* z_f, const float* norm, PixelRay* rays, float& tile_max, Tally& tally) const {
    const __m128d z = loadTwo(z_f), range = _mm_mul_pd(z, loadTwo(norm));
    const __m128d min_r = _mm_set1_pd(min_r_), max_r = _mm_set1_pd(max_r_), delta = _mm_set1_pd(delta_);
    // Finite and positive (NaN fails every comparison); range is then finite too.
    const __m128d finite = _mm_and_pd(_mm_cmpgt_pd(z, _mm_setzero_pd()),
                                      _mm_cmplt_pd(z, _mm_set1_pd(std::numeric_limits<double>::infinity())));
    const int valid = _mm_movemask_pd(_mm_and_pd(finite, _mm_cmpge_pd(range, min_r)));
    if (valid == 0) {
      rays[0] = rays[1] = PixelRay{};
      tally.invalid += 2;
      return;
    }
    const __m128d beyond = _mm_cmpgt_pd(range, max_r);
    const __m128d r_m = select(beyond, max_r, range);
    alignas(16) std::int64_t weight[2] = {scale_, scale_};
    if (!constant_) {
      // Most pairs have no pixel beyond max range, and need no second division.
      const __m128d z_eff = _mm_movemask_pd(beyond) ? select(beyond, _mm_div_pd(_mm_mul_pd(z, max_r), range), z) : z;
      const __m128d w = _mm_add_pd(_mm_div_pd(_mm_set1_pd(double(scale_)), _mm_mul_pd(z_eff, z_eff)), _mm_set1_pd(0.5));
      weight[0] = _mm_cvttsd_si64(w);  // roundToInt64 of a value >= 0
      weight[1] = _mm_cvttsd_si64(_mm_unpackhi_pd(w, w));
    }
    // Selected in double, then rounded: float(-1.0) is -1.0f, and band2 of a far pixel is free2.
    const __m128d below = _mm_sub_pd(r_m, delta), above = _mm_add_pd(r_m, delta);
    const __m128d free2 = select(_mm_cmpge_pd(r_m, delta), _mm_mul_pd(below, below), _mm_set1_pd(-1.0));
    const __m128 range_f = _mm_cvtpd_ps(r_m);
    const __m128 free2_f = _mm_cvtpd_ps(free2);
    const __m128 band2_f = _mm_cvtpd_ps(select(beyond, free2, _mm_mul_pd(above, above)));
    alignas(16) float f_range[4], f_free2[4], f_band2[4];
    _mm_store_ps(f_range, range_f);
    _mm_store_ps(f_free2, free2_f);
    _mm_store_ps(f_band2, band2_f);
    finish<2>(valid, _mm_movemask_pd(beyond), weight, f_range, f_free2, f_band2, rays, tile_max, tally);
  }

#if VDBMAP_AVX2_KERNELS
  /// Pixels u to u + 3 in lanes 0 to 3: pair() four wide, the same operations lane by lane.
  VDBMAP_TARGET_AVX2 void quad(const float* z_f, const float* norm, PixelRay* rays, float& tile_max,
                               Tally& tally) const {
    const __m256d z = _mm256_cvtps_pd(_mm_loadu_ps(z_f)), range = _mm256_mul_pd(z, _mm256_cvtps_pd(_mm_loadu_ps(norm)));
    const __m256d min_r = _mm256_set1_pd(min_r_), max_r = _mm256_set1_pd(max_r_), delta = _mm256_set1_pd(delta_);
    const __m256d finite =
        _mm256_and_pd(_mm256_cmp_pd(z, _mm256_setzero_pd(), _CMP_GT_OQ),
                      _mm256_cmp_pd(z, _mm256_set1_pd(std::numeric_limits<double>::infinity()), _CMP_LT_OQ));
    const int valid = _mm256_movemask_pd(_mm256_and_pd(finite, _mm256_cmp_pd(range, min_r, _CMP_GE_OQ)));
    if (valid == 0) {
      rays[0] = rays[1] = rays[2] = rays[3] = PixelRay{};
      tally.invalid += 4;
      return;
    }
    const __m256d beyond = _mm256_cmp_pd(range, max_r, _CMP_GT_OQ);
    const __m256d r_m = _mm256_blendv_pd(range, max_r, beyond);
    std::int64_t weight[4] = {scale_, scale_, scale_, scale_};
    if (!constant_) {
      const __m256d z_eff =
          _mm256_movemask_pd(beyond) ? _mm256_blendv_pd(z, _mm256_div_pd(_mm256_mul_pd(z, max_r), range), beyond) : z;
      const __m256d w = _mm256_add_pd(_mm256_div_pd(_mm256_set1_pd(double(scale_)), _mm256_mul_pd(z_eff, z_eff)),
                                      _mm256_set1_pd(0.5));
      alignas(32) double w_lanes[4];
      _mm256_store_pd(w_lanes, w);
      for (int l = 0; l < 4; ++l) weight[l] = _mm_cvttsd_si64(_mm_set_sd(w_lanes[l]));  // as pair()
    }
    const __m256d below = _mm256_sub_pd(r_m, delta), above = _mm256_add_pd(r_m, delta);
    const __m256d free2 =
        _mm256_blendv_pd(_mm256_set1_pd(-1.0), _mm256_mul_pd(below, below), _mm256_cmp_pd(r_m, delta, _CMP_GE_OQ));
    alignas(16) float f_range[4], f_free2[4], f_band2[4];
    _mm_store_ps(f_range, _mm256_cvtpd_ps(r_m));
    _mm_store_ps(f_free2, _mm256_cvtpd_ps(free2));
    _mm_store_ps(f_band2, _mm256_cvtpd_ps(_mm256_blendv_pd(_mm256_mul_pd(above, above), free2, beyond)));
    finish<4>(valid, _mm256_movemask_pd(beyond), weight, f_range, f_free2, f_band2, rays, tile_max, tally);
  }
#endif

  /// Writes lanes 0 to N - 1 as pixel() would: invalid where `valid` lacks the lane's bit or the
  /// weight rounded to 0, beyond max range where `far` has it.
  template <int N>
  static void finish(int valid, int far, const std::int64_t* weight, const float* f_range, const float* f_free2,
                     const float* f_band2, PixelRay* rays, float& tile_max, Tally& tally) {
    // Maxima and counts in locals: through the references, every record written would force them
    // back to memory (the compiler cannot tell that they do not alias).
    float lanes_max = -1.0f;
    std::size_t invalid = 0, beyond = 0;
    for (int l = 0; l < N; ++l) {
      if (!(valid & (1 << l)) || weight[l] == 0) {
        rays[l] = PixelRay{};
        ++invalid;
        continue;
      }
      if (far & (1 << l)) ++beyond;
      rays[l].weight_q = weight[l];
      rays[l].range_m = f_range[l];
      rays[l].free2 = f_free2[l];
      rays[l].band2 = f_band2[l];
      lanes_max = std::max(lanes_max, f_range[l]);
    }
    tally.invalid += invalid;
    tally.beyond += beyond;
    if (lanes_max >= 0.0f) {
      tile_max = std::max(tile_max, lanes_max);
      tally.max_range_m = std::max(tally.max_range_m, double(lanes_max));
    }
  }
#endif

  double min_r_, max_r_, delta_;
  std::int64_t scale_;
  bool constant_;
};

}  // namespace vdbmap::internal
