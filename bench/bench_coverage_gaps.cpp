// Where the unknown part of an exploration run's observable surface lies, and whether a planner
// reasoning on the run's final map could have seen it.
//
//   vdbmap_bench_coverage_gaps --world W.ply RUNDIR [--ceiling 2.5]
//
// reads RUNDIR/map.vdb and RUNDIR/summary.json (box, start), rebuilds the world's observable
// surface as `vdbmap explore` does, and sorts every observable sample the map does not know:
//   - map-visible: some witness point sees it with a line of sight the final map does not block;
//   - through gaps only: every witness's line of sight crosses an occupied voxel of the final map
//     (the camera sees the surface through a gap narrower than the map resolves, e.g. between
//     shelf boards), or no witness keeps the planner's clearance in the map.
// A witness is a point 0.3-4.5 m from the sample along a direction a level camera could look
// (36 azimuths x 9 elevations within the vertical half field of view) before the ray meets the
// world, inside the box, with every voxel within the path clearance (0.3 m) known-free in the
// final map. Occupied voxels within 1.5 voxels of the sample do not block (they hold the sample's
// own surface). Also printed: unknown samples by height, how many map-visible witnesses sit in
// the viewpoints' height band (0.5 m inside the box), and, for the map-visible ones, the size of
// the frontier component where the witness's line of sight leaves known space: what a planner's
// min cluster size (FUEL's 100, our final sweep's 30) would have to be to target it. Last, the
// planner clusters (final sweep size, 30) with the most map-visible samples behind them, the
// viewpoints computeViewpoints finds for them in the final map (the --fallback-* options try
// other fallback settings), and how far the samples' witnesses are from the cluster's centroid.
#include "vdbmap/planner/frontier.hpp"
#include "vdbmap/planner/map_query.hpp"
#include "vdbmap/planner/tsdf_map_query.hpp"
#include "vdbmap/planner/viewpoint.hpp"
#include "vdbmap/sim/surface_coverage.hpp"
#include "vdbmap/sim/world.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <tbb/parallel_for.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>
#include <string>

using namespace vdbmap;

namespace {

constexpr double kClearance_m = 0.3;  // the planner's path and viewpoint clearance
constexpr double kMinRange_m = 0.3, kMaxRange_m = 4.5;
constexpr double kStep_m = 0.1;
constexpr double kOwnSurfaceVox = 1.5;  // occupied voxels this close to the sample are its own surface
constexpr double kBandMargin_m = 0.5;   // ExplorationManagerConfig::viewpoint_margin_z_m
constexpr int kAzimuths = 36, kElevations = 9;

enum Witness { kNone = 0, kMapVisible = 1, kMapVisibleInBand = 2 };

struct WitnessResult {
  Witness kind = kNone;
  Vec3d position_W = Vec3d::Zero();  ///< the best witness (valid unless kind is kNone)
};

WitnessResult bestWitness(const sim::World& world, planner::MapProbe& probe, const Eigen::AlignedBox3d& box,
                          const Vec3d& sample) {
  const double half_fov = std::atan(240.0 / 387.229);
  const double vox = probe.voxelSize();
  WitnessResult best;
  for (int a = 0; a < kAzimuths; ++a)
    for (int e = 0; e < kElevations; ++e) {
      const double az = 2.0 * M_PI * a / kAzimuths, el = -half_fov + 2.0 * half_fov * e / (kElevations - 1);
      const Vec3d dir(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      const double lift = 0.02;  // start just off the surface so the ray does not hit it
      const sim::RayHit hit = world.raycast(sample + dir * lift, dir, kMaxRange_m);
      const double t_end = hit.hit() ? hit.t + lift : kMaxRange_m;
      // The map's line of sight from the sample outwards, blocked at the first occupied voxel.
      double blocked_at = t_end;
      for (double u = kOwnSurfaceVox * vox; u < t_end; u += 0.5 * vox)
        if (probe.atWorld(sample + dir * u) == planner::Occupancy::Occupied) {
          blocked_at = u;
          break;
        }
      for (double t = kMinRange_m; t < std::min(t_end, blocked_at); t += kStep_m) {
        const Vec3d p = sample + dir * t;
        if (!box.contains(p)) break;
        if (!probe.isClear(p, kClearance_m)) continue;
        const bool in_band = p.z() >= box.min().z() + kBandMargin_m && p.z() <= box.max().z() - kBandMargin_m;
        const Witness kind = in_band ? kMapVisibleInBand : kMapVisible;
        if (kind > best.kind) best = {kind, p};
        if (best.kind == kMapVisibleInBand) return best;
      }
    }
  return best;
}

struct FrontierOnSight {
  std::size_t component_size = 0;  ///< 0: no frontier voxel there
  openvdb::Coord voxel;            ///< the frontier voxel of the largest component there
};

// The frontier component where the line of sight from a witness to its sample first meets an
// unknown voxel: the largest component with a voxel within a voxel of that spot.
FrontierOnSight frontierOnSight(planner::MapProbe& probe, const planner::FrontierMap& frontiers,
                                const std::map<openvdb::Coord, std::size_t>& component_size, const Vec3d& witness_W,
                                const Vec3d& sample_W) {
  const double vox = probe.voxelSize();
  const Vec3d d = sample_W - witness_W;
  const double len = d.norm();
  Vec3d last_free = witness_W;
  for (double t = 0.0; t < len; t += 0.25 * vox) {
    const Vec3d p = witness_W + d * (t / len);
    if (probe.atWorld(p) != planner::Occupancy::Unknown) {
      last_free = p;
      continue;
    }
    const openvdb::Coord c = probe.map().worldToVoxel(last_free);
    FrontierOnSight best;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const openvdb::Coord n = c.offsetBy(dx, dy, dz);
          if (!frontiers.isFrontier(n)) continue;
          const std::size_t size = component_size.at(n);
          if (size > best.component_size) best = {size, n};
        }
    return best;
  }
  return {};
}

Vec3d vec3(const nlohmann::json& j) {
  return Vec3d(j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>());
}

}  // namespace

int main(int argc, char** argv) {
  std::filesystem::path world_path, run_dir;
  double ceiling_m = 2.5;
  planner::ViewpointFallback fallback;  // the planner's, unless overridden to try others
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--world" && has_value)
      world_path = argv[++i];
    else if (a == "--ceiling" && has_value)
      ceiling_m = std::atof(argv[++i]);
    else if (a == "--fallback-clearance" && has_value)
      fallback.min_clearance_m = std::atof(argv[++i]);
    else if (a == "--fallback-fraction" && has_value)
      fallback.min_visible_fraction = std::atof(argv[++i]);
    else if (a == "--fallback-radius-max" && has_value)
      fallback.ring_radius_max_m = std::atof(argv[++i]);
    else if (a == "--fallback-rings" && has_value)
      fallback.ring_count = std::atoi(argv[++i]);
    else if (a == "--fallback-min-visible" && has_value)
      fallback.min_visible_samples = std::atoi(argv[++i]);
    else
      run_dir = a;
  }
  if (world_path.empty() || run_dir.empty()) {
    std::fprintf(stderr,
                 "usage: %s --world W.ply RUNDIR [--ceiling 2.5] [--fallback-clearance M] [--fallback-fraction F]\n"
                 "       [--fallback-radius-max M] [--fallback-rings N] [--fallback-min-visible K]   (the viewpoint "
                 "fallback of the cluster table)\n",
                 argv[0]);
    return 2;
  }
  try {
    initializeOpenVdb();
    sim::WorldConfig wc;
    if (ceiling_m > 0.0) wc.ceiling_clip_z_m = ceiling_m, wc.cap_ceiling = true;
    const sim::World world = sim::World::load(world_path, wc);
    std::ifstream summary_file(run_dir / "summary.json");
    if (!summary_file) throw std::runtime_error((run_dir / "summary.json").string() + ": cannot open");
    const nlohmann::json summary = nlohmann::json::parse(summary_file);
    const Eigen::AlignedBox3d box(vec3(summary.at("box").at("min")), vec3(summary.at("box").at("max")));
    const Vec3d start = vec3(summary.at("start"));
    const TsdfVolume volume = TsdfVolume::load(run_dir / "map.vdb");
    const planner::TsdfMapQuery map(volume);

    const sim::ObservableSurface observable(world, box, start);
    const std::vector<bool> known = observable.known(map);
    std::vector<std::size_t> unknown;
    for (std::size_t i = 0; i < known.size(); ++i)
      if (!known[i]) unknown.push_back(i);

    // Every frontier component of the final map, unsplit: min cluster size 1, no split radius.
    planner::FrontierConfig fp;
    fp.min_cluster_size = 1;
    fp.split_radius_xy_m = 1e4;
    fp.bounds_W = box;
    planner::FrontierMap frontiers(fp);
    frontiers.rebuild(map);
    std::map<openvdb::Coord, std::size_t> component_size;
    for (const planner::FrontierCluster& c : frontiers.clusters())
      for (const openvdb::Coord& v : c.voxels) component_size[v] = c.voxels.size();

    std::vector<Witness> witness(unknown.size(), kNone);
    std::vector<FrontierOnSight> on_sight(unknown.size());
    std::vector<Vec3d> witness_at(unknown.size(), Vec3d::Zero());
    tbb::parallel_for(std::size_t(0), unknown.size(), [&](std::size_t k) {
      planner::MapProbe probe(map);
      const Vec3d& sample = observable.samples()[unknown[k]];
      const WitnessResult w = bestWitness(world, probe, box, sample);
      witness[k] = w.kind;
      witness_at[k] = w.position_W;
      if (w.kind != kNone) on_sight[k] = frontierOnSight(probe, frontiers, component_size, w.position_W, sample);
    });

    std::size_t visible = 0, in_band = 0;
    std::map<int, std::pair<std::size_t, std::size_t>> by_height;  // 0.25 m bands: unknown, through gaps only
    for (std::size_t k = 0; k < unknown.size(); ++k) {
      visible += witness[k] != kNone;
      in_band += witness[k] == kMapVisibleInBand;
      auto& band = by_height[int(std::floor(observable.samples()[unknown[k]].z() / 0.25))];
      ++band.first;
      band.second += witness[k] == kNone;
    }
    const double n = double(known.size());
    std::printf("observable samples %zu, known %zu (coverage %.4f)\n", known.size(), known.size() - unknown.size(),
                1.0 - double(unknown.size()) / n);
    std::printf("unknown %zu (%.2f %% of observable):\n", unknown.size(), 100.0 * double(unknown.size()) / n);
    std::printf("  map-visible from a clear witness   %6zu (%.2f %%), %zu of them from the viewpoints' height band\n",
                visible, 100.0 * double(visible) / n, in_band);
    std::printf("  through gaps only / no clear witness %4zu (%.2f %%)\n", unknown.size() - visible,
                100.0 * double(unknown.size() - visible) / n);
    // Map-visible samples by the size of the frontier component on the witness's line of sight.
    const std::size_t bounds[] = {1, 10, 30, 100};
    std::size_t by_size[5] = {0, 0, 0, 0, 0};
    for (std::size_t k = 0; k < unknown.size(); ++k) {
      if (witness[k] == kNone) continue;
      std::size_t b = 0;
      while (b < 4 && on_sight[k].component_size >= bounds[b]) ++b;
      ++by_size[b];
    }
    std::printf("map-visible, by the frontier component where the witness's sight enters unknown space:\n");
    std::printf("  no frontier voxel there %6zu\n", by_size[0]);
    std::printf("  component 1-9 voxels    %6zu\n", by_size[1]);
    std::printf("  component 10-29         %6zu\n", by_size[2]);
    std::printf("  component 30-99         %6zu\n", by_size[3]);
    std::printf("  component >= 100        %6zu\n", by_size[4]);
    std::printf("frontier components %zu, frontier voxels %zu\n", frontiers.clusters().size(),
                frontiers.frontierVoxelCount());
    // The planner's clusters at the final sweep's size (30, split at 2 m) that map-visible samples
    // lie behind, most samples first, with the viewpoints the planner would find in the final map.
    {
      planner::FrontierConfig cp;
      cp.min_cluster_size = 30;
      cp.bounds_W = box;
      planner::FrontierMap clusters(cp);
      clusters.rebuild(map);
      std::map<openvdb::Coord, std::size_t> cluster_of;  // voxel -> index into clusters.clusters()
      for (std::size_t i = 0; i < clusters.clusters().size(); ++i)
        for (const openvdb::Coord& v : clusters.clusters()[i].voxels) cluster_of[v] = i;
      std::map<std::size_t, std::size_t> samples_behind;                // cluster index -> map-visible samples
      std::map<std::size_t, std::array<std::size_t, 4>> witness_range;  // witness distance to the centroid
      for (std::size_t k = 0; k < unknown.size(); ++k) {
        if (witness[k] == kNone || on_sight[k].component_size == 0) continue;
        const auto it = cluster_of.find(on_sight[k].voxel);
        if (it == cluster_of.end()) continue;
        ++samples_behind[it->second];
        const double d = (witness_at[k] - clusters.clusters()[it->second].centroid_W).norm();
        ++witness_range[it->second][d < 1.5 ? 0 : d < 2.5 ? 1 : d < 3.5 ? 2 : 3];
      }
      std::vector<std::pair<std::size_t, std::size_t>> ranked(samples_behind.begin(), samples_behind.end());
      std::sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
      if (ranked.size() > 15) ranked.resize(15);
      planner::ViewpointConfig vp;  // as ExplorationManager sets them: box shrunk by the clearance, 0.5 m in z
      const Vec3d margin(vp.min_clearance_m, vp.min_clearance_m, std::max(vp.min_clearance_m, kBandMargin_m));
      vp.bounds_W = Eigen::AlignedBox3d(box.min() + margin, box.max() - margin);
      vp.fallback = fallback;
      vp.validate();
      std::printf("planner clusters (>= 30 voxels) with the most map-visible samples behind them:\n");
      std::printf("  %8s %7s %20s %10s %12s\n", "samples", "voxels", "centroid (m)", "viewpoints", "best sees");
      for (const auto& [index, count] : ranked) {
        const planner::FrontierCluster& c = clusters.clusters()[index];
        const std::vector<planner::Viewpoint> views = planner::computeViewpoints(c, map, vp);
        const auto& wr = witness_range[index];
        std::printf(
            "  %8zu %7zu  (%5.1f, %5.1f, %4.1f) %10zu %12d   witnesses <1.5/<2.5/<3.5/more m: %zu/%zu/%zu/%zu\n", count,
            c.voxels.size(), c.centroid_W.x(), c.centroid_W.y(), c.centroid_W.z(), views.size(),
            views.empty() ? 0 : views.front().visible_samples, wr[0], wr[1], wr[2], wr[3]);
      }
    }
    std::printf("by height (unknown / through gaps only):\n");
    for (const auto& [band, counts] : by_height)
      std::printf("  z %5.2f-%5.2f m  %6zu / %6zu\n", band * 0.25, band * 0.25 + 0.25, counts.first, counts.second);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
