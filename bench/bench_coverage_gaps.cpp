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
// own surface). Also printed: unknown samples by height, and how many map-visible witnesses sit in
// the viewpoints' height band (0.5 m inside the box).
#include "vdbmap/planner/map_query.hpp"
#include "vdbmap/planner/tsdf_map_query.hpp"
#include "vdbmap/sim/surface_coverage.hpp"
#include "vdbmap/sim/world.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

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

constexpr double kClearance_m = 0.3;       // the planner's path and viewpoint clearance
constexpr double kMinRange_m = 0.3, kMaxRange_m = 4.5;
constexpr double kStep_m = 0.1;
constexpr double kOwnSurfaceVox = 1.5;     // occupied voxels this close to the sample are its own surface
constexpr double kBandMargin_m = 0.5;      // ExplorationParams::viewpoint_margin_z_m
constexpr int kAzimuths = 36, kElevations = 9;

enum Witness { kNone = 0, kMapVisible = 1, kMapVisibleInBand = 2 };

Witness bestWitness(const sim::World& world, planner::MapProbe& probe, const Eigen::AlignedBox3d& box,
                    const Vec3d& sample) {
  const double half_fov = std::atan(240.0 / 387.229);
  const double vox = probe.voxelSize();
  Witness best = kNone;
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
        best = std::max(best, in_band ? kMapVisibleInBand : kMapVisible);
        if (best == kMapVisibleInBand) return best;
      }
    }
  return best;
}

Vec3d vec3(const nlohmann::json& j) { return Vec3d(j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()); }

}  // namespace

int main(int argc, char** argv) {
  std::filesystem::path world_path, run_dir;
  double ceiling_m = 2.5;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--world" && i + 1 < argc) world_path = argv[++i];
    else if (a == "--ceiling" && i + 1 < argc) ceiling_m = std::atof(argv[++i]);
    else run_dir = a;
  }
  if (world_path.empty() || run_dir.empty()) {
    std::fprintf(stderr, "usage: %s --world W.ply RUNDIR [--ceiling 2.5]\n", argv[0]);
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

    std::vector<Witness> witness(unknown.size(), kNone);
    tbb::parallel_for(std::size_t(0), unknown.size(), [&](std::size_t k) {
      planner::MapProbe probe(map);
      witness[k] = bestWitness(world, probe, box, observable.samples()[unknown[k]]);
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
    std::printf("by height (unknown / through gaps only):\n");
    for (const auto& [band, counts] : by_height)
      std::printf("  z %5.2f-%5.2f m  %6zu / %6zu\n", band * 0.25, band * 0.25 + 0.25, counts.first, counts.second);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
