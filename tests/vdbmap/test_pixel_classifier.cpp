// Pixel classification for projective integration: the row pass (two pixels at a time on x86-64,
// four with AVX2) against its one-pixel reference, bit for bit, on every kind of depth.
#include "internal/pixel_classifier.hpp"

#include <catch2/catch.hpp>

#include <cstring>
#include <limits>
#include <random>
#include <vector>

using namespace vdbmap;
using internal::PixelClassifier;
using internal::PixelRay;

namespace {

bool sameBits(float a, float b) { return std::memcmp(&a, &b, sizeof(float)) == 0; }

/// Depths of every kind the classification treats apart, for a camera with these limits.
float randomDepth(std::mt19937& rng, const IntegratorConfig& in, double truncation_m) {
  const float inf = std::numeric_limits<float>::infinity();
  std::uniform_int_distribution<int> kind(0, 8);
  auto uniform = [&](double lo, double hi) { return float(std::uniform_real_distribution<double>(lo, hi)(rng)); };
  switch (kind(rng)) {
    case 0: return std::numeric_limits<float>::quiet_NaN();
    case 1: return std::uniform_int_distribution<int>(0, 1)(rng) ? inf : -inf;
    case 2: return std::uniform_int_distribution<int>(0, 1)(rng) ? 0.0f : -uniform(0.0, 2.0);
    case 3: return uniform(0.0, in.min_range_m);                                     // too close
    case 4: return uniform(in.min_range_m, std::max(in.min_range_m, truncation_m));  // nearer than the truncation
    case 5: return uniform(in.min_range_m, in.max_range_m);
    case 6: return float(in.max_range_m);                          // at max range
    case 7: return uniform(in.max_range_m, 3.0 * in.max_range_m);  // beyond: carves only
    default: return uniform(0.5 * in.min_range_m, 2.0 * in.max_range_m);
  }
}

}  // namespace

TEST_CASE("the pixel row pass classifies every pixel bit for bit as the one-pixel reference", "[projective][pixels]") {
  std::vector<internal::SimdLevel> levels{internal::SimdLevel::Sse2};
  if (internal::simdLevel() == internal::SimdLevel::Avx2)
    levels.push_back(internal::SimdLevel::Avx2);
  else
    WARN("this CPU has no AVX2: the four-pixel path is not compared");
  struct Case {
    const char* name;
    double min_range_m, max_range_m, truncation_vox, voxel_m;
    Weighting weighting;
    std::int64_t weight_scale;  // 0: chosen from the range
  };
  const Case cases[] = {
      {"inverse square", 0.3, 4.0, 3.0, 0.05, Weighting::InverseSquare, 0},
      {"constant", 0.3, 4.0, 3.0, 0.05, Weighting::Constant, 0},
      {"truncation beyond min range", 0.05, 3.0, 10.0, 0.05, Weighting::InverseSquare, 0},
      {"weights that round to 0 (a small scale set by hand, far range)", 0.5, 100.0, 3.0, 0.05,
       Weighting::InverseSquare, 1024},
      // A truncation of 0.25 m, a float: ranges of exactly the truncation (the free-space limit's edge).
      {"ranges equal to the truncation", 0.1, 3.0, 4.0, 0.0625, Weighting::InverseSquare, 0},
  };
  std::mt19937 rng(20261127);
  for (const Case& c : cases) {
    INFO(c.name);
    TsdfConfig tsdf;
    tsdf.voxel_size_m = c.voxel_m;
    tsdf.truncation_vox = c.truncation_vox;
    tsdf.weighting = c.weighting;
    tsdf.weight_scale = c.weight_scale;
    IntegratorConfig in;
    in.min_range_m = c.min_range_m;
    in.max_range_m = c.max_range_m;
    const PixelClassifier classifier(tsdf, in);
    for (const int width : {1, 2, 3, 4, 5, 7, 64, 641})
      for (const internal::SimdLevel level : levels) {
        INFO("width " << width << ", SIMD level " << int(level));
        std::vector<float> z(static_cast<std::size_t>(width)), norm(static_cast<std::size_t>(width));
        for (int u = 0; u < width; ++u) {
          z[std::size_t(u)] = randomDepth(rng, in, tsdf.truncation_m());
          norm[std::size_t(u)] = float(std::uniform_real_distribution<double>(1.0, 1.6)(rng));
          if (float(tsdf.truncation_m()) == tsdf.truncation_m() && u % 3 == 0) {
            z[std::size_t(u)] = float(tsdf.truncation_m());  // range exactly the truncation
            norm[std::size_t(u)] = 1.0f;
          }
        }
        const int tiles = (width + internal::kPixelTile - 1) / internal::kPixelTile;
        std::vector<PixelRay> rays(static_cast<std::size_t>(width));
        std::vector<float> tile_max(static_cast<std::size_t>(tiles), -1.0f), expected_tile_max(tile_max);
        PixelClassifier::Tally tally, expected;
        classifier.row(z.data(), norm.data(), width, rays.data(), tile_max.data(), tally, level);
        std::size_t differ = 0, valid = 0;
        for (int u = 0; u < width; ++u) {
          const PixelRay e = classifier.pixel(z[std::size_t(u)], norm[std::size_t(u)], expected);
          const PixelRay& r = rays[std::size_t(u)];
          if (e.weight_q != 0) {
            ++valid;
            float& m = expected_tile_max[std::size_t(u / internal::kPixelTile)];
            m = std::max(m, e.range_m);
          }
          const bool same = r.weight_q == e.weight_q && sameBits(r.range_m, e.range_m) && sameBits(r.free2, e.free2) &&
                            sameBits(r.band2, e.band2);
          if (!same) UNSCOPED_INFO("pixel " << u << " depth " << z[std::size_t(u)] << " norm " << norm[std::size_t(u)]);
          differ += same ? 0 : 1;
        }
        CHECK(differ == 0);
        CHECK(tally.invalid == expected.invalid);
        CHECK(tally.beyond == expected.beyond);
        CHECK(tally.max_range_m == expected.max_range_m);
        CHECK(tile_max == expected_tile_max);
        if (width == 641) CHECK(valid > 100);  // the row is not all invalid
      }
  }
}
