// Set-cover pruning: compact cell sets, visible cells against the integrator's voxels, the greedy
// against a plain greedy and brute force, its coverage guarantees, and the incremental pruner.
#include "internal/simd.hpp"
#include "tsdf_test_helpers.hpp"

#include "vdbmap/camera.hpp"
#include "vdbmap/set_cover.hpp"
#include "vdbmap/testing/analytic_scene.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <tuple>

using namespace vdbmap;
using openvdb::Coord;
using vdbmap::internal::SimdLevel;
using Sets = std::vector<std::vector<Coord>>;

namespace {

constexpr int kInstances = 300;  // random instances per property

/// Each element index becomes a distinct scattered cell, negative coordinates included.
Coord cellOfElement(int e) { return Coord(3 * e - 40, -(e % 7) - 1, (e * 13) % 11 - 5); }

Sets toCells(const std::vector<std::vector<int>>& sets) {
  Sets out;
  for (const auto& s : sets) {
    std::vector<Coord> cells;
    for (const int e : s) cells.push_back(cellOfElement(e));
    out.push_back(cells);
  }
  return out;
}

/// Random sets over `universe` elements; each element is in a set with probability p.
std::vector<std::vector<int>> randomSets(std::mt19937& rng, int n_sets, int universe, double p) {
  std::bernoulli_distribution in(p);
  std::vector<std::vector<int>> sets(static_cast<std::size_t>(n_sets));
  for (auto& s : sets)
    for (int e = 0; e < universe; ++e)
      if (in(rng)) s.push_back(e);
  return sets;
}

/// A random laminar family (any two sets nested or disjoint): intervals of a random recursive
/// partition of [lo, hi), each kept with probability 0.6, sometimes twice.
void laminar(std::mt19937& rng, int lo, int hi, int depth, std::vector<std::vector<int>>& out) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  if (u(rng) < 0.6) {
    std::vector<int> s;
    for (int e = lo; e < hi; ++e) s.push_back(e);
    out.push_back(s);
    if (u(rng) < 0.15) out.push_back(s);
  }
  if (hi - lo < 2 || depth == 0) return;
  const int parts = std::uniform_int_distribution<int>(2, 3)(rng);
  int start = lo;
  for (int k = 1; k <= parts && start < hi; ++k) {
    const int end = k == parts ? hi : std::uniform_int_distribution<int>(start + 1, std::max(start + 1, hi - 1))(rng);
    laminar(rng, start, end, depth - 1, out);
    start = end;
  }
}

std::map<Coord, int> degrees(const Sets& sets) {
  std::map<Coord, int> deg;
  for (const auto& s : sets)
    for (const Coord& c : std::set<Coord>(s.begin(), s.end())) ++deg[c];
  return deg;
}

std::map<Coord, int> coverOf(const Sets& sets, const std::vector<std::size_t>& chosen) {
  std::map<Coord, int> cover;
  for (const std::size_t i : chosen)
    for (const Coord& c : std::set<Coord>(sets[i].begin(), sets[i].end())) ++cover[c];
  return cover;
}

/// Every cell covered min(n_ob, deg) times.
bool satisfies(const Sets& sets, const std::vector<std::size_t>& chosen, int n_ob) {
  const auto deg = degrees(sets);
  auto cover = coverOf(sets, chosen);
  for (const auto& [c, d] : deg)
    if (cover[c] < std::min(n_ob, d)) return false;
  return true;
}

/// The smallest number of sets that satisfies the requirement, by enumerating all subsets.
std::size_t bruteForceMinimum(const Sets& sets, int n_ob) {
  const std::size_t n = sets.size();
  REQUIRE(n <= 16);
  std::size_t best = n;
  for (std::uint32_t mask = 0; mask < (1u << n); ++mask) {
    const std::size_t k = std::size_t(__builtin_popcount(mask));
    if (k >= best) continue;
    std::vector<std::size_t> chosen;
    for (std::size_t i = 0; i < n; ++i)
      if (mask & (1u << i)) chosen.push_back(i);
    if (satisfies(sets, chosen, n_ob)) best = k;
  }
  return best;
}

/// The plain greedy written directly from the definition: counters in a map, every gain
/// recomputed every round, largest gain first, the lowest index on ties, stop when <= tau.
std::vector<std::size_t> plainGreedy(const Sets& sets, int n_ob, double tau_gain) {
  std::map<Coord, int> counter;
  for (const auto& s : sets)
    for (const Coord& c : s) counter[c] = n_ob;
  std::vector<char> taken(sets.size(), 0);
  std::vector<std::size_t> order;
  while (true) {
    long best_gain = -1;
    std::size_t best = 0;
    for (std::size_t i = 0; i < sets.size(); ++i) {
      if (taken[i]) continue;
      long gain = 0;
      for (const Coord& c : std::set<Coord>(sets[i].begin(), sets[i].end())) gain += counter[c] > 0;
      if (gain > best_gain) {
        best_gain = gain;
        best = i;
      }
    }
    if (best_gain < 0 || double(best_gain) <= tau_gain) break;
    taken[best] = 1;
    order.push_back(best);
    for (const Coord& c : std::set<Coord>(sets[best].begin(), sets[best].end())) --counter[c];
  }
  return order;
}

/// A flat wall in front of a camera at the origin looking along +z (OpenCV axes).
PointCloud wallFrame(int width, int height, double f, double depth_m) {
  PointCloud points;
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u)
      points.emplace_back(float((u - width / 2 + 0.5) * depth_m / f), float((v - height / 2 + 0.5) * depth_m / f),
                          float(depth_m));
  return points;
}

TsdfConfig tsdfConfig(double voxel_size_m) {
  TsdfConfig c;
  c.voxel_size_m = voxel_size_m;
  return c;
}

}  // namespace

TEST_CASE("SetCoverConfig validates every field", "[set_cover][config]") {
  REQUIRE_NOTHROW(SetCoverConfig{}.validate());
  const auto fails = [](auto mutate, const std::string& field) {
    SetCoverConfig c;
    mutate(c);
    try {
      c.validate();
      FAIL("no exception for " << field);
    } catch (const std::invalid_argument& e) {
      CHECK_THAT(e.what(), Catch::Contains(field));
    }
  };
  fails([](SetCoverConfig& c) { c.n_ob = 0; }, "n_ob");
  fails([](SetCoverConfig& c) { c.tau_gain = -1; }, "tau_gain");
  fails([](SetCoverConfig& c) { c.tau_gain = std::numeric_limits<double>::quiet_NaN(); }, "tau_gain");
  fails([](SetCoverConfig& c) { c.block_size_m = 0; }, "block_size_m");
  fails([](SetCoverConfig& c) { c.cell_size_vox = 0.5; }, "cell_size_vox");
  fails([](SetCoverConfig& c) { c.solve_period_frames = 0; }, "solve_period_frames");
  CHECK_THROWS_AS(FramePruner(SetCoverConfig{}, 0.0), std::invalid_argument);
  CHECK_THROWS_AS(greedyCover(Sets{}, 0, 0.0), std::invalid_argument);
  CHECK_THROWS_AS(greedyCover(Sets{}, 1, -0.5), std::invalid_argument);
}

TEST_CASE("CellSet stores sorted unique cells compactly and round-trips", "[set_cover][cells]") {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> coord(-(1 << 20), (1 << 20) - 1), small(-30, 30);
  std::vector<Coord> cells;
  for (int i = 0; i < 2000; ++i) cells.emplace_back(coord(rng), coord(rng), coord(rng));
  for (int i = 0; i < 2000; ++i) cells.emplace_back(small(rng), small(rng), small(rng));
  cells.push_back(cells.front());  // a duplicate
  const CellSet set = CellSet::fromCoords(cells);
  std::set<Coord> expected(cells.begin(), cells.end());
  const std::vector<Coord> back = set.toCoords();
  REQUIRE(back.size() == expected.size());
  CHECK(std::equal(back.begin(), back.end(), expected.begin()));  // Coord's order is (x, y, z)
  for (const Coord& c : back) CHECK(unpackCell(packCell(c)) == c);

  CHECK_THROWS_AS(packCell(Coord(1 << 20, 0, 0)), std::out_of_range);
  CHECK_THROWS_AS(packCell(Coord(0, -(1 << 20) - 1, 0)), std::out_of_range);
  CHECK_THROWS_AS(CellSet::fromSortedKeys({5, 5}), std::invalid_argument);

  // A solid 40^3 block of cells, as a frustum is: about one byte per cell (8 for raw keys).
  std::vector<Coord> box;
  for (int x = 0; x < 40; ++x)
    for (int y = 0; y < 40; ++y)
      for (int z = 0; z < 40; ++z) box.emplace_back(x - 20, y - 20, z);
  const CellSet solid = CellSet::fromCoords(box);
  CHECK(solid.size() == box.size());
  CHECK(double(solid.memoryBytes()) / double(solid.size()) < 1.2);
}

TEST_CASE("CellSet's z runs are maximal and hold exactly its cells", "[set_cover][cells]") {
  std::mt19937 rng(5);
  for (int k = 0; k < kInstances; ++k) {
    // Columns of random z spans, some touching, some at the packable range's ends (z's field full).
    std::vector<Coord> cells;
    std::uniform_int_distribution<int> xy(-3, 3), z0(-40, 40), len(1, 30);
    for (int c = std::uniform_int_distribution<int>(0, 12)(rng); c > 0; --c) {
      const int x = xy(rng), y = xy(rng), z = z0(rng), n = len(rng);
      for (int i = 0; i < n; ++i) cells.emplace_back(x, y, z + i);
    }
    if (k % 3 == 0) cells.emplace_back(0, 0, (1 << 20) - 1), cells.emplace_back(0, 1, -(1 << 20));
    const CellSet set = CellSet::fromCoords(cells);
    std::vector<Coord> from_runs;
    bool maximal = true;
    Coord previous_end(INT_MAX);
    set.forEachRun([&](const Coord& first, int length) {
      REQUIRE(length >= 1);
      if (first == previous_end) maximal = false;  // would continue the previous run
      for (int i = 0; i < length; ++i) from_runs.emplace_back(first.x(), first.y(), first.z() + i);
      previous_end = Coord(first.x(), first.y(), first.z() + length);
    });
    INFO("instance " << k);
    CHECK(from_runs == set.toCoords());
    CHECK(maximal);
  }
}

TEST_CASE("Cells are unions of voxels and the cell transform maps to cell centres", "[set_cover][cells]") {
  const double vs = 0.05;
  for (int i = -7; i <= 7; ++i) {
    const Vec3d centre = Vec3d::Constant(i * vs);  // voxel i's centre
    const int expected = int(std::floor(i / 2.0));
    CHECK(cellOf(centre, vs, 2.0) == Coord(expected));
    CHECK(cellOf(centre + Vec3d::Constant(0.49 * vs), vs, 2.0) == Coord(expected));
  }
  const auto xform = cellTransform(vs, 2.0);
  for (int c = -3; c <= 3; ++c) {
    const openvdb::Vec3d w = xform->indexToWorld(Coord(c));
    // cell c = voxels 2c and 2c + 1: its centre is halfway between their centres
    CHECK(w.x() == Approx((2 * c + 0.5) * vs));
    CHECK(cellOf(Vec3d(w.x(), w.y(), w.z()), vs, 2.0) == Coord(c));
  }
}

TEST_CASE("footprintCells holds the cells of every voxel of the footprint, for every cell size", "[set_cover][cells]") {
  // Brute force: each voxel v of the footprint lies in cell floor((v + 0.5) / k). Leaves sit in a
  // small box (negative coordinates included) so that many share their x or x and y, masks range
  // from single voxels to full rows and full leaves, and one leaf is listed twice. Cell sizes 1, 2,
  // 4 and 8 take the leaf-aligned path, 3 and 2.5 the general one; so does a footprint whose
  // origins are not multiples of 8.
  std::mt19937 rng(91);
  std::uniform_int_distribution<int> leaf_coord(-3, 2), bit(0, 511), kind(0, 3);
  const auto brute = [](const VoxelFootprint& fp, double k) {
    std::vector<Coord> cells;
    for (const LeafFootprint& leaf : fp)
      for (int n = 0; n < 512; ++n)
        if ((leaf.voxels[std::size_t(n >> 6)] >> (n & 63)) & 1) {
          const Coord v = leaf.origin.offsetBy(n >> 6, (n >> 3) & 7, n & 7);
          cells.emplace_back(int(std::floor((v.x() + 0.5) / k)), int(std::floor((v.y() + 0.5) / k)),
                             int(std::floor((v.z() + 0.5) / k)));
        }
    return CellSet::fromCoords(cells);
  };
  for (int instance = 0; instance < 50; ++instance) {
    VoxelFootprint fp;
    std::set<std::tuple<int, int, int>> used;
    for (int l = 0; l < 40; ++l) {
      const int x = leaf_coord(rng), y = leaf_coord(rng), z = leaf_coord(rng);
      if (!used.insert({x, y, z}).second) continue;
      LeafFootprint leaf;
      leaf.origin = Coord(8 * x, 8 * y, 8 * z);
      switch (kind(rng)) {
        case 0: leaf.voxels[std::size_t(bit(rng) >> 6)] |= std::uint64_t(1) << (bit(rng) & 63); break;
        case 1: leaf.voxels[std::size_t(bit(rng) & 7)] = ~std::uint64_t(0); break;
        case 2: leaf.voxels.fill(~std::uint64_t(0)); break;
        default:
          for (int b = 0; b < 40; ++b) leaf.voxels[std::size_t(bit(rng) >> 6)] |= std::uint64_t(1) << (bit(rng) & 63);
      }
      fp.push_back(leaf);
    }
    fp.push_back(fp.front());
    for (const double k : {1.0, 2.0, 4.0, 8.0, 3.0, 2.5}) {
      INFO("instance " << instance << ", cell size " << k);
      CHECK(footprintCells(fp, k) == brute(fp, k));
    }
    VoxelFootprint shifted = fp;
    for (LeafFootprint& leaf : shifted) leaf.origin = leaf.origin.offsetBy(3, -5, 1);
    CHECK(footprintCells(shifted, 2.0) == brute(shifted, 2.0));
  }
}

TEST_CASE("visibleCells holds the cells of every voxel the integrator touches", "[set_cover][visible]") {
  initializeOpenVdb();
  const double vs = 0.05;
  const TsdfConfig tsdf = tsdfConfig(vs);
  IntegratorConfig integrator;
  integrator.max_range_m = 3.0;
  const testing::AnalyticScene scene = testing::AnalyticScene::demoRoom();
  const CameraIntrinsics K = test::smallCamera();
  // Point clouds have no image: under Projective they are integrated (and walked) as Merged rays.
  for (const RayMode mode : {RayMode::Merged, RayMode::PerRay, RayMode::Projective}) {
    integrator.ray_mode = mode;
    for (const Pose3d& T : {vdbmap::lookingPose({0.5, 0.3, 1.2}, 0.4, 0.1), vdbmap::lookingPose({-1.5, 0.8, 1.5}, 2.5, -0.2)}) {
      // depth up to 10 m so that some points are beyond max range (carve-only rays)
      const PointCloud points = backProject(scene.renderDepth(K, T, 10.0), K);
      TsdfVolume map(tsdf, integrator);
      const IntegrationStats stats = map.integrate(1, points, T);
      REQUIRE(stats.points_beyond_range > 0);
      const CellSet visible = visibleCells(points, T, tsdf, integrator, 2.0);
      const std::vector<Coord> cells = visible.toCoords();
      const std::set<Coord> visible_set(cells.begin(), cells.end());

      std::set<Coord> integrated;  // coarse cells of the voxels the integration wrote
      for (auto it = map.weightSumGrid()->cbeginValueOn(); it; ++it) {
        const Coord v = it.getCoord();
        integrated.insert(Coord(v.x() >> 1, v.y() >> 1, v.z() >> 1));  // floor(v / 2)
      }
      std::size_t missing = 0;
      for (const Coord& c : integrated) missing += visible_set.count(c) == 0;
      INFO("missing " << missing << " of " << integrated.size() << " cells");
      CHECK(missing == 0);
      // The extra cells are where a ray crosses a cell without writing its voxels (behind the
      // surface beyond -truncation): a thin shell, a few percent at most.
      const double extra = double(visible_set.size() - (integrated.size() - missing)) / double(visible_set.size());
      CHECK(extra < 0.05);
      CHECK(visible_set.count(cellOf(T.translation(), vs, 2.0)) == 1);
    }
  }
}

TEST_CASE("visibleCells of a depth image under Projective are the cells of the voxels its integration writes",
          "[set_cover][visible]") {
  initializeOpenVdb();
  const double vs = 0.05;
  const TsdfConfig tsdf = tsdfConfig(vs);
  IntegratorConfig integrator;
  integrator.max_range_m = 3.0;
  REQUIRE(integrator.ray_mode == RayMode::Projective);
  const testing::AnalyticScene scene = testing::AnalyticScene::demoRoom();
  const CameraIntrinsics K = test::smallCamera();
  // Level and pitched views: the floor and ceiling are seen only near the frustum's edges, which
  // is where sampled rays would miss cells the integration writes.
  for (const Pose3d& T : {vdbmap::lookingPose({0.5, 0.3, 1.2}, 0.4, 0.0), vdbmap::lookingPose({-1.5, 0.8, 1.5}, 2.5, -0.2)}) {
    const DepthImage depth = scene.renderDepth(K, T, 10.0);  // beyond max range too: carve-only pixels
    TsdfVolume map(tsdf, integrator);
    const IntegrationStats stats = map.integrate(1, depth, K, T);
    REQUIRE(stats.points_beyond_range > 0);
    for (const double k : {2.0, 3.0}) {
      const std::vector<Coord> cells = visibleCells(depth, K, T, tsdf, integrator, k).toCoords();
      const std::set<Coord> visible(cells.begin(), cells.end());
      std::set<Coord> written;  // cell of voxel v: floor((v + 0.5) / k)
      const auto cell = [k](int v) { return int(std::floor((v + 0.5) / k)); };
      for (auto it = map.weightSumGrid()->cbeginValueOn(); it; ++it)
        written.insert(Coord(cell(it.getCoord().x()), cell(it.getCoord().y()), cell(it.getCoord().z())));
      INFO("cell size " << k << " voxels: " << visible.size() << " visible, " << written.size() << " written");
      std::size_t missing = 0;
      for (const Coord& c : written) missing += visible.count(c) == 0;
      CHECK(missing == 0);
      // Extra cells hold only band voxels behind the surface whose weight dropped to zero.
      CHECK(double(visible.size() - written.size()) / double(visible.size()) < 0.02);
      CHECK(written.size() > 1000);
    }
  }
}

TEST_CASE("visibleCells of a wall: a frustum with free space, ending past the wall", "[set_cover][visible]") {
  const double vs = 0.05, depth = 2.0;
  const TsdfConfig tsdf = tsdfConfig(vs);
  const IntegratorConfig integrator;
  const PointCloud wall = wallFrame(64, 48, 64.0, depth);  // about 2 x 1.5 m at 2 m
  const CellSet cells = visibleCells(wall, Pose3d::Identity(), tsdf, integrator, 2.0);
  int max_z = std::numeric_limits<int>::min();
  std::size_t on_axis = 0;
  cells.forEach([&](const Coord& c) {
    max_z = std::max(max_z, c.z());
    on_axis += c.x() == 0 && c.y() == 0;
  });
  // The wall is at 2 m; surface rays go on for the truncation (0.15 m): the last cells are at
  // floor((2.15 / 0.05 + 0.5) / 2) = 21.
  CHECK(max_z == 21);
  CHECK(on_axis == 22);  // the whole optical axis, cells 0..21: free space is in the set
  // Moving the camera moves the set by whole cells.
  Pose3d T = Pose3d::Identity();
  T.translation() = Vec3d(1.0, 0.0, 0.0);  // 10 cells
  const std::vector<Coord> moved = visibleCells(wall, T, tsdf, integrator, 2.0).toCoords();
  std::vector<Coord> shifted = cells.toCoords();
  for (Coord& c : shifted) c = c + Coord(10, 0, 0);
  CHECK(moved == shifted);
  CHECK(visibleCells(PointCloud{}, T, tsdf, integrator, 2.0).empty());
  Pose3d bad = Pose3d::Identity();
  bad.linear() *= 2.0;
  CHECK_THROWS_AS(visibleCells(wall, bad, tsdf, integrator, 2.0), std::invalid_argument);
  CHECK_THROWS_AS(visibleCells(wall, T, tsdf, integrator, 0.0), std::invalid_argument);
}

TEST_CASE("n_ob = 1, tau_gain = 0 is the classic greedy; any n_ob and tau equal the plain greedy",
          "[set_cover][greedy]") {
  std::mt19937 rng(11);
  for (int k = 0; k < kInstances; ++k) {
    const int n_sets = std::uniform_int_distribution<int>(1, 14)(rng);
    const int universe = std::uniform_int_distribution<int>(1, 30)(rng);
    const Sets sets = toCells(randomSets(rng, n_sets, universe, 0.25));
    INFO("instance " << k);
    CHECK(greedyCover(sets, 1, 0.0) == plainGreedy(sets, 1, 0.0));
    const int n_ob = std::uniform_int_distribution<int>(1, 4)(rng);
    const double tau = std::uniform_int_distribution<int>(0, 4)(rng) * 0.75;
    CHECK(greedyCover(sets, n_ob, tau) == plainGreedy(sets, n_ob, tau));
  }
  // The textbook case where greedy is not optimal: two halves vs. a big middle set.
  const Sets classic = toCells({{0, 1, 2, 3, 4, 5, 6}, {7, 8, 9, 10, 11, 12, 13}, {0, 1, 2, 3, 7, 8, 9, 10},
                                {4, 5, 11, 12}, {6, 13}});
  CHECK(greedyCover(classic, 1, 0.0) == std::vector<std::size_t>{2, 3, 4});
  CHECK(bruteForceMinimum(classic, 1) == 2);
}

TEST_CASE("Greedy never leaves a cell below min(n_ob, deg) when tau_gain = 0", "[set_cover][greedy]") {
  std::mt19937 rng(12);
  for (int k = 0; k < kInstances; ++k) {
    const int n_sets = std::uniform_int_distribution<int>(1, 16)(rng);
    const int universe = std::uniform_int_distribution<int>(1, 40)(rng);
    const double p = std::uniform_real_distribution<double>(0.05, 0.6)(rng);
    const Sets sets = toCells(randomSets(rng, n_sets, universe, p));
    const int n_ob = std::uniform_int_distribution<int>(1, 5)(rng);
    INFO("instance " << k << " n_ob " << n_ob);
    const auto chosen = greedyCover(sets, n_ob, 0.0);
    CHECK(satisfies(sets, chosen, n_ob));
    CHECK(std::set<std::size_t>(chosen.begin(), chosen.end()).size() == chosen.size());
    if (n_sets <= 12) CHECK(bruteForceMinimum(sets, n_ob) <= chosen.size());
    if (n_ob == 1 && n_sets <= 12) {
      // Chvatal: greedy <= H(largest set) * OPT.
      std::size_t largest = 0;
      for (const auto& s : sets) largest = std::max(largest, s.size());
      double harmonic = 0.0;
      for (std::size_t i = 1; i <= largest; ++i) harmonic += 1.0 / double(i);
      CHECK(double(chosen.size()) <= harmonic * double(bruteForceMinimum(sets, 1)) + 1e-9);
    }
  }
}

TEST_CASE("With tau_gain > 0 each dropped set leaves at most floor(tau) under-covered cells",
          "[set_cover][greedy]") {
  std::mt19937 rng(13);
  for (int k = 0; k < kInstances; ++k) {
    const int n_sets = std::uniform_int_distribution<int>(1, 16)(rng);
    const int universe = std::uniform_int_distribution<int>(5, 60)(rng);
    const Sets sets = toCells(randomSets(rng, n_sets, universe, 0.3));
    const int n_ob = std::uniform_int_distribution<int>(1, 4)(rng);
    const double tau = std::uniform_real_distribution<double>(0.5, 6.0)(rng);
    INFO("instance " << k << " n_ob " << n_ob << " tau " << tau);
    const auto chosen = greedyCover(sets, n_ob, tau);
    const auto deg = degrees(sets);
    auto cover = coverOf(sets, chosen);
    std::set<std::size_t> selected(chosen.begin(), chosen.end());
    std::size_t dropped = 0, deficient = 0;
    for (std::size_t i = 0; i < sets.size(); ++i) {
      if (selected.count(i)) continue;
      ++dropped;
      std::size_t still_needed = 0;
      for (const Coord& c : std::set<Coord>(sets[i].begin(), sets[i].end())) still_needed += cover[c] < n_ob;
      CHECK(double(still_needed) <= tau);
    }
    for (const auto& [c, d] : deg) deficient += cover[c] < std::min(n_ob, d);
    CHECK(double(deficient) <= std::floor(tau) * double(dropped));
    // Each selection gained more than tau when it was made.
    std::map<Coord, int> counter;
    for (const std::size_t i : chosen) {
      std::size_t gain = 0;
      for (const Coord& c : std::set<Coord>(sets[i].begin(), sets[i].end())) gain += counter[c]++ < n_ob;
      CHECK(double(gain) > tau);
    }
  }
}

TEST_CASE("Greedy equals the brute-force minimum where it is provably optimal", "[set_cover][greedy]") {
  std::mt19937 rng(14);
  SECTION("laminar families, n_ob = 1") {
    for (int k = 0; k < kInstances; ++k) {
      std::vector<std::vector<int>> family;
      const int universe = std::uniform_int_distribution<int>(2, 24)(rng);
      laminar(rng, 0, universe, 4, family);
      if (family.empty() || family.size() > 14) continue;
      std::shuffle(family.begin(), family.end(), rng);
      const Sets sets = toCells(family);
      INFO("instance " << k << " with " << sets.size() << " sets");
      const auto chosen = greedyCover(sets, 1, 0.0);
      CHECK(satisfies(sets, chosen, 1));
      CHECK(chosen.size() == bruteForceMinimum(sets, 1));
    }
  }
  SECTION("no cell seen by more than n_ob sets") {
    for (int k = 0; k < kInstances; ++k) {
      const int n_ob = std::uniform_int_distribution<int>(1, 4)(rng);
      const int n_sets = std::uniform_int_distribution<int>(1, 12)(rng);
      // Each element joins at most n_ob random sets.
      std::vector<std::vector<int>> family(static_cast<std::size_t>(n_sets));
      const int universe = std::uniform_int_distribution<int>(0, 20)(rng);
      for (int e = 0; e < universe; ++e) {
        const int copies = std::uniform_int_distribution<int>(1, n_ob)(rng);
        std::vector<int> ids(static_cast<std::size_t>(n_sets), 0);
        for (int i = 0; i < n_sets; ++i) ids[std::size_t(i)] = i;
        std::shuffle(ids.begin(), ids.end(), rng);
        for (int j = 0; j < std::min(copies, n_sets); ++j) family[std::size_t(ids[std::size_t(j)])].push_back(e);
      }
      const Sets sets = toCells(family);
      INFO("instance " << k << " n_ob " << n_ob);
      const auto chosen = greedyCover(sets, n_ob, 0.0);
      std::size_t non_empty = 0;
      for (const auto& s : sets) non_empty += !s.empty();
      CHECK(chosen.size() == non_empty);
      CHECK(chosen.size() == bruteForceMinimum(sets, n_ob));
    }
  }
}

TEST_CASE("The greedy over sets of long z runs equals the plain greedy", "[set_cover][greedy]") {
  // Frustum-like sets: boxes of columns whose z spans cross the counters' 8-cell leaves, with
  // negative coordinates, overlapping so that counters go to zero and below within a span.
  std::mt19937 rng(23);
  for (int k = 0; k < 60; ++k) {
    Sets sets(std::size_t(std::uniform_int_distribution<int>(1, 10)(rng)));
    std::uniform_int_distribution<int> lo(-12, 4), extent(1, 9), zlo(-20, 10), zlen(1, 25);
    for (auto& s : sets) {
      const int x0 = lo(rng), y0 = lo(rng), nx = extent(rng), ny = extent(rng);
      for (int x = x0; x < x0 + nx; ++x)
        for (int y = y0; y < y0 + ny; ++y) {
          const int z = zlo(rng), n = zlen(rng);
          for (int i = 0; i < n; ++i) s.emplace_back(x, y, z + i);
        }
    }
    INFO("instance " << k);
    const int n_ob = std::uniform_int_distribution<int>(1, 4)(rng);
    const double tau = std::uniform_int_distribution<int>(0, 40)(rng);
    CHECK(greedyCover(sets, n_ob, tau) == plainGreedy(sets, n_ob, tau));
  }
}

TEST_CASE("The greedy over runs across 64-cell columns equals the plain greedy at every SIMD level",
          "[set_cover][greedy]") {
  // The greedy's counters group cells in columns of 64 along z and 4 x 4 columns per brick: runs
  // here start and end on both sides of multiples of 64 (negative ones too), fill whole columns,
  // and several runs share one column. Also n_ob above the number of sets, so the counters start
  // lower than n_ob.
  std::mt19937 rng(29);
  for (int k = 0; k < 80; ++k) {
    Sets sets(std::size_t(std::uniform_int_distribution<int>(1, 9)(rng)));
    std::uniform_int_distribution<int> lo(-10, 6), extent(1, 8), zlo(-140, 80), zlen(1, 150), runs(1, 3);
    for (auto& s : sets) {
      const int x0 = lo(rng), y0 = lo(rng), nx = extent(rng), ny = extent(rng);
      for (int x = x0; x < x0 + nx; ++x)
        for (int y = y0; y < y0 + ny; ++y)
          for (int r = runs(rng); r > 0; --r) {
            const int z = zlo(rng), n = zlen(rng);
            for (int i = 0; i < n; ++i) s.emplace_back(x, y, z + i);
          }
    }
    INFO("instance " << k);
    const int n_ob = std::uniform_int_distribution<int>(1, 12)(rng);
    const double tau = std::uniform_int_distribution<int>(0, 200)(rng);
    const auto expected = plainGreedy(sets, n_ob, tau);
    for (const SimdLevel level : {SimdLevel::Scalar, SimdLevel::Avx2}) {
      const internal::ScopedSimdCap cap(level);
      INFO("SIMD cap " << int(level));
      CHECK(greedyCover(sets, n_ob, tau) == expected);
    }
  }
}

TEST_CASE("FramePruner re-solves only the blocks that got frames", "[set_cover][pruner]") {
  initializeOpenVdb();
  SetCoverConfig config;
  config.n_ob = 1;
  config.tau_gain = 0.0;
  config.block_size_m = 5.0;
  FramePruner pruner(config, 0.05);
  const Vec3d in_a(1.0, 1.0, 1.0), in_b(7.0, 1.0, 1.0);  // blocks (0,0,0) and (1,0,0)
  const auto cells = [](int lo, int hi) {
    std::vector<Coord> c;
    for (int i = lo; i < hi; ++i) c.emplace_back(i, 0, 0);
    return c;
  };
  pruner.addFrame(1, in_a, cells(0, 10));
  pruner.addFrame(2, in_a, cells(0, 5));  // inside frame 1: redundant
  pruner.addFrame(3, in_b, cells(0, 10));  // the same cells, but another block
  pruner.addFrame(4, in_b, cells(5, 15));
  CHECK(pruner.dirtyBlockCount() == 2);
  CHECK(pruner.isKept(2));  // held until a solve drops it

  FramePruner::Result r = pruner.solve();
  CHECK(r.blocks_solved == 2);
  CHECK(r.dropped == std::vector<FrameId>{2});
  CHECK(r.frames_kept == 3);
  CHECK(pruner.dirtyBlockCount() == 0);
  CHECK_FALSE(pruner.isKept(2));
  CHECK(pruner.isKept(1));
  CHECK(pruner.isKept(3));  // blocks are solved apart: frame 1 does not make frame 3 redundant

  // Nothing new: nothing is solved.
  r = pruner.solve();
  CHECK(r.blocks_solved == 0);
  CHECK(r.dropped.empty());

  // New frames in block A only: block B is not re-solved, though frame 5 covers frame 4's cells.
  pruner.addFrame(5, in_a, cells(0, 20));
  CHECK(pruner.dirtyBlockCount() == 1);
  r = pruner.solve();
  CHECK(r.blocks_solved == 1);
  CHECK(r.solved_blocks == std::vector<Coord>{pruner.blockOf(in_a)});
  // Frame 1 was kept before; frame 5 now covers all of it, so the re-solve drops it.
  CHECK(r.dropped == std::vector<FrameId>{1});
  CHECK(pruner.framesInBlock(pruner.blockOf(in_a)) == std::vector<FrameId>{5});
  CHECK(pruner.framesInBlock(pruner.blockOf(in_b)) == (std::vector<FrameId>{3, 4}));

  CHECK_THROWS_AS(pruner.addFrame(5, in_a, cells(0, 1)), std::invalid_argument);
  CHECK_THROWS_AS(pruner.removeFrame(1), std::invalid_argument);  // dropped: gone
  pruner.removeFrame(3);
  CHECK_FALSE(pruner.isKept(3));
  CHECK(pruner.dirtyBlockCount() == 0);  // removal does not trigger a re-solve
  pruner.removeFrame(4);
  CHECK(pruner.blockCount() == 1);
  CHECK_THROWS_AS(pruner.addFrame(9, Vec3d(std::nan(""), 0, 0), cells(0, 1)), std::invalid_argument);
}

TEST_CASE("A solve taken, run apart and finished drops only frames unchanged since it was taken",
          "[set_cover][pruner]") {
  initializeOpenVdb();
  SetCoverConfig config;
  config.n_ob = 1;
  config.tau_gain = 0.0;
  const Vec3d in_a(1.0, 1.0, 1.0), in_b(7.0, 1.0, 1.0);
  const auto cells = [](int lo, int hi) {
    std::vector<Coord> c;
    for (int i = lo; i < hi; ++i) c.emplace_back(i, 0, 0);
    return c;
  };
  const auto fill = [&](FramePruner& p) {
    p.addFrame(1, in_a, cells(0, 10));
    p.addFrame(2, in_a, cells(0, 5));  // redundant
    p.addFrame(3, in_a, cells(2, 6));  // redundant
    p.addFrame(4, in_a, cells(8, 9));  // redundant
    p.addFrame(5, in_b, cells(0, 10));
    p.addFrame(6, in_b, cells(0, 3));  // redundant
  };

  // Nothing changes in between: the same as solve().
  FramePruner at_once(config, 0.05), split(config, 0.05);
  fill(at_once);
  fill(split);
  const FramePruner::Result expected = at_once.solve();
  PruningSolve job = split.beginSolve();
  CHECK(job.blockCount() == 2);
  CHECK(split.dirtyBlockCount() == 0);  // taken
  CHECK(split.beginSolve().blockCount() == 0);
  CHECK_THROWS_AS(split.finishSolve(PruningSolve(job)), std::logic_error);  // not run yet
  job.run();
  CHECK(job.hasRun());
  CHECK_THROWS_AS(job.run(), std::logic_error);
  const FramePruner::Result r = split.finishSolve(std::move(job));
  CHECK(r.dropped == expected.dropped);
  CHECK(r.dropped == (std::vector<FrameId>{2, 3, 4, 6}));
  CHECK(r.solved_blocks == expected.solved_blocks);
  CHECK(r.frames_kept == expected.frames_kept);

  // Changes while the solve runs: an updated frame (3), a removed one (4) and a new one (7).
  FramePruner p(config, 0.05);
  fill(p);
  PruningSolve running = p.beginSolve();
  p.updateFrame(3, in_a, CellSet::fromCoords(cells(20, 30)));  // re-integrated elsewhere: now needed
  p.removeFrame(4);
  p.addFrame(7, in_b, cells(0, 10));  // the same as frame 5: the next solve drops one
  running.run();
  const FramePruner::Result late = p.finishSolve(std::move(running));
  CHECK(late.dropped == (std::vector<FrameId>{2, 6}));  // not 3 (changed) nor 4 (gone)
  CHECK(p.isKept(3));
  CHECK(p.isKept(7));
  CHECK(p.dirtyBlockCount() == 2);  // 3's block and 7's: the next solve sees them as they are
  const FramePruner::Result next = p.solve();
  CHECK(next.dropped == std::vector<FrameId>{7});  // ties go to the older frame
  CHECK(p.isKept(3));
}

TEST_CASE("FramePruner keeps each block's coverage and its counters match", "[set_cover][pruner]") {
  initializeOpenVdb();
  std::mt19937 rng(15);
  for (const int n_ob : {1, 2, 3}) {
    SetCoverConfig config;
    config.n_ob = n_ob;
    config.tau_gain = 0.0;
    config.block_size_m = 2.0;
    FramePruner pruner(config, 0.1);
    std::map<FrameId, std::vector<Coord>> all_cells;
    std::map<FrameId, Coord> block_of;
    FrameId next = 0;
    std::uniform_real_distribution<double> pos(-3.0, 3.0);
    for (int round = 0; round < 4; ++round) {
      const int new_frames = std::uniform_int_distribution<int>(1, 12)(rng);
      for (int f = 0; f < new_frames; ++f) {
        const Vec3d p(pos(rng), pos(rng), 0.5);
        std::vector<Coord> cells;
        const int cx = int(std::floor(p.x() * 10)), cy = int(std::floor(p.y() * 10));
        std::uniform_int_distribution<int> d(-4, 4);
        for (int i = 0; i < 30; ++i) cells.emplace_back(cx + d(rng), cy + d(rng), d(rng));
        all_cells[next] = cells;
        block_of[next] = pruner.blockOf(p);
        pruner.addFrame(next++, p, cells);
      }
      std::set<Coord> dirty;
      for (const auto& [id, b] : block_of)
        if (pruner.isKept(id) && id >= next - FrameId(new_frames)) dirty.insert(b);
      // Before the solve: each dirty block's frames and the expected greedy choice.
      std::map<Coord, std::vector<FrameId>> before;
      for (const Coord& b : dirty) before[b] = pruner.framesInBlock(b);
      const FramePruner::Result r = pruner.solve();
      CHECK(r.blocks_solved == dirty.size());
      CHECK(std::set<Coord>(r.solved_blocks.begin(), r.solved_blocks.end()) == dirty);
      for (const auto& [b, ids] : before) {
        Sets sets;
        for (const FrameId id : ids) sets.push_back(all_cells[id]);
        const auto chosen = greedyCover(sets, n_ob, 0.0);
        std::vector<FrameId> expected;
        for (const std::size_t i : chosen) expected.push_back(ids[i]);
        std::sort(expected.begin(), expected.end());
        CHECK(pruner.framesInBlock(b) == expected);
        // Coverage within the block, and the counters grid says n_ob - cover.
        const auto deg = degrees(sets);
        std::map<Coord, int> cover;
        for (const FrameId id : expected)
          for (const Coord& c : std::set<Coord>(all_cells[id].begin(), all_cells[id].end())) ++cover[c];
        const auto grid = pruner.visibilityCounters(b);
        CHECK(grid->background() == n_ob);
        auto acc = grid->getConstAccessor();
        for (const auto& [c, d] : deg) {
          CHECK(cover[c] >= std::min(n_ob, d));
          CHECK(acc.getValue(c) == n_ob - cover[c]);
        }
      }
      for (const FrameId id : r.dropped) CHECK_FALSE(pruner.isKept(id));
      CHECK(r.frames_kept == pruner.frameCount());
    }
  }
}

TEST_CASE("FramePruner drops repeated views of real frames", "[set_cover][pruner]") {
  initializeOpenVdb();
  const double vs = 0.1;
  const TsdfConfig tsdf = tsdfConfig(vs);
  const IntegratorConfig integrator;
  const testing::AnalyticScene scene = testing::AnalyticScene::demoRoom();
  const CameraIntrinsics K = test::smallCamera();
  SetCoverConfig config;
  config.n_ob = 1;
  FramePruner pruner(config, vs);
  // Frames 1 and 2 are copies of frame 0, frames 3 and 4 nearly so; frame 5 looks the other way.
  std::vector<Pose3d> poses;
  for (int i = 0; i < 3; ++i) poses.push_back(vdbmap::lookingPose({0.0, 0.0, 1.2}, 0.3, 0.0));
  for (int i = 1; i <= 2; ++i) poses.push_back(vdbmap::lookingPose({0.0, 0.0, 1.2}, 0.3 + 0.002 * i, 0.0));
  poses.push_back(vdbmap::lookingPose({0.0, 0.0, 1.2}, 0.3 + M_PI, 0.0));
  std::size_t bytes_cells = 0, n_cells = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    CellSet cells = visibleCells(backProject(scene.renderDepth(K, poses[i], 5.0), K), poses[i], tsdf, integrator,
                                 config.cell_size_vox);
    REQUIRE(cells.size() > 1000);
    bytes_cells += cells.memoryBytes();
    n_cells += cells.size();
    pruner.addFrame(FrameId(i), poses[i].translation(), std::move(cells));
  }
  CHECK(double(bytes_cells) / double(n_cells) < 2.5);  // compact: well under 8 bytes per cell
  const FramePruner::Result r = pruner.solve();
  CHECK(r.blocks_solved == 1);
  CHECK(pruner.isKept(5));  // the only view of its side of the room
  CHECK_FALSE(pruner.isKept(1));  // copies gain nothing once one of them is kept
  CHECK_FALSE(pruner.isKept(2));
  INFO("dropped " << r.dropped.size() << " of " << poses.size());
  CHECK(r.frames_kept + r.dropped.size() == poses.size());
  CHECK(pruner.memoryBytes() >= bytes_cells / 3);
}
