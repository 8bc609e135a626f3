// Adding hit runs to a count grid, leaf by leaf in parallel, against a map of sums.
#include "internal/hit_counter.hpp"

#include <catch2/catch.hpp>

#include <map>
#include <random>
#include <tuple>
#include <vector>

using namespace vdbmap;
using internal::HitRun;

TEST_CASE("hit runs add each voxel's summed count and remove voxels that return to 0", "[hits]") {
  openvdb::initialize();
  std::mt19937 rng(23);
  const auto pick = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  openvdb::Int64Grid::Ptr hits = openvdb::Int64Grid::create(0);
  std::map<std::tuple<int, int, int>, std::int64_t> expected;
  std::vector<std::vector<HitRun>> batches;
  for (int batch = 0; batch < 6; ++batch) {
    // Voxels on both sides of 0 in a few neighbouring leaves and far ones; repeated keys; counts
    // that cancel within a batch or against earlier batches.
    std::vector<HitRun> runs;
    for (int i = 0; i < 3000; ++i) {
      const int far = pick(0, 9) == 0 ? 4096 * pick(-3, 3) : 0;
      const openvdb::Coord c(pick(-20, 20) + far, pick(-12, 12), pick(-4000, -3990));
      const std::int64_t count = pick(-3, 3);
      runs.push_back({internal::packVoxel(c), count});
      expected[{c.x(), c.y(), c.z()}] += count;
    }
    internal::applyHitRuns(runs, *hits);
    batches.push_back(runs);

    std::size_t nonzero = 0;
    for (const auto& [c, n] : expected) {
      const openvdb::Coord xyz(std::get<0>(c), std::get<1>(c), std::get<2>(c));
      REQUIRE(hits->tree().getValue(xyz) == n);
      REQUIRE(hits->tree().isValueOn(xyz) == (n != 0));
      nonzero += n != 0 ? 1 : 0;
    }
    REQUIRE(hits->activeVoxelCount() == nonzero);
  }
  // Every batch taken back: no voxel, no leaf and no branch is left.
  for (std::vector<HitRun>& runs : batches) {
    for (HitRun& run : runs) run.count = -run.count;
    internal::applyHitRuns(runs, *hits);
  }
  REQUIRE(hits->activeVoxelCount() == 0);
  REQUIRE(hits->tree().leafCount() == 0);
  REQUIRE(hits->tree().empty());
}
