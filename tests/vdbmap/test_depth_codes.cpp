// The keyframe store's depth codes: every SIMD level gives depthCode()'s and codeDepth()'s results
// bit for bit, on depths around every boundary the codes have.
#include "internal/depth_codes.hpp"

#include <catch2/catch.hpp>

#include <cstring>
#include <limits>
#include <random>
#include <vector>

using namespace vdbmap::internal;

namespace {

/// Depths of every kind: invalid ones, those at and around code boundaries ((k + 0.5) units), the
/// clamps at 1 and 65535 units, and random ones; lengths not a multiple of any lane count.
std::vector<float> hardDepths(double unit_m, std::mt19937& rng) {
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> d = {std::numeric_limits<float>::quiet_NaN(),
                          inf,
                          -inf,
                          0.0f,
                          -0.0f,
                          -1.0f,
                          std::numeric_limits<float>::denorm_min(),
                          std::numeric_limits<float>::min(),
                          std::numeric_limits<float>::max(),
                          float(0.4 * unit_m),
                          float(unit_m),
                          float(65535.0 * unit_m),
                          float(65535.6 * unit_m),
                          float(1e6 * unit_m)};
  std::uniform_int_distribution<int> code(0, 65535);
  for (int i = 0; i < 4000; ++i) {
    const float b = float((code(rng) + 0.5) * unit_m);  // a boundary and its float neighbours
    d.push_back(b);
    d.push_back(std::nextafter(b, 0.0f));
    d.push_back(std::nextafter(b, inf));
    d.push_back(float(std::uniform_real_distribution<double>(0.0, 70000.0 * unit_m)(rng)));
  }
  d.push_back(1.0f);  // an odd length
  return d;
}

}  // namespace

TEST_CASE("depth codes are the same at every SIMD level", "[keyframes][simd]") {
  std::mt19937 rng(5);
  for (const double unit_m : {0.001, 0.0002, 1.0 / 3000.0, 0.005}) {
    const std::vector<float> depths = hardDepths(unit_m, rng);
    std::vector<std::uint16_t> reference(depths.size());
    std::vector<float> reference_depths(depths.size());
    for (std::size_t i = 0; i < depths.size(); ++i) {
      reference[i] = depthCode(depths[i], unit_m);
      reference_depths[i] = codeDepth(reference[i], unit_m);
    }
    for (const SimdLevel level : {SimdLevel::Scalar, SimdLevel::Sse2, SimdLevel::Avx2}) {
      // Every start offset, so that each value meets every lane.
      for (std::size_t first = 0; first < 4; ++first) {
        const std::size_t n = depths.size() - first;
        std::vector<std::uint16_t> codes(n, 7);
        depthCodes(depths.data() + first, n, unit_m, codes.data(), level);
        std::vector<float> decoded(n, -5.0f);
        codeDepths(codes.data(), n, unit_m, decoded.data(), level);
        std::size_t wrong_codes = 0, wrong_depths = 0;
        for (std::size_t i = 0; i < n; ++i) {
          wrong_codes += codes[i] != reference[first + i] ? 1 : 0;
          wrong_depths += std::memcmp(&decoded[i], &reference_depths[first + i], sizeof(float)) != 0 ? 1 : 0;
        }
        INFO("unit " << unit_m << " m, level " << int(level) << ", first " << first);
        REQUIRE(wrong_codes == 0);
        REQUIRE(wrong_depths == 0);
      }
    }
  }
}
