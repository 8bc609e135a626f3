#include "vdbmap/sim/surface_coverage.hpp"
#include "vdbmap/field_check.hpp"
#include "vdbmap/timing.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <deque>
#include <random>
#include <stdexcept>
#include <string>

namespace vdbmap::sim {

void SurfaceCoverageConfig::validate() const {
  const FieldCheck check("SurfaceCoverageConfig");
  if (!(sample_spacing_m >= 0.005 && sample_spacing_m <= 1.0)) check.fail("sample_spacing_m", "[0.005, 1]");
  if (!(grid_m >= 0.02 && grid_m <= 1.0)) check.fail("grid_m", "[0.02, 1]");
  if (!(vehicle_clearance_m >= 0.0 && vehicle_clearance_m <= 10.0)) check.fail("vehicle_clearance_m", "[0, 10]");
  if (!(max_view_distance_m > 0.0 && max_view_distance_m <= 100.0)) check.fail("max_view_distance_m", "(0, 100]");
  if (!(min_view_distance_m >= 0.0 && min_view_distance_m < max_view_distance_m))
    check.fail("min_view_distance_m", "[0, max_view_distance_m)");
  if (!(half_fov_vertical_rad > 0.0 && half_fov_vertical_rad <= M_PI / 2)) check.fail("half_fov_vertical_rad", "(0, pi/2]");
  if (azimuth_steps < 1 || azimuth_steps > 360) check.fail("azimuth_steps", "[1, 360]");
  if (elevation_steps < 1 || elevation_steps > 90) check.fail("elevation_steps", "[1, 90]");
  if (!(known_radius_vox >= 0.0 && known_radius_vox <= 10.0)) check.fail("known_radius_vox", "[0, 10]");
}

std::vector<Vec3d> sampleSurface(const TriangleMesh& mesh, double spacing_m, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double per_m2 = 1.0 / (spacing_m * spacing_m);
  std::vector<Vec3d> samples;
  for (const Eigen::Vector3i& tri : mesh.triangles) {
    const Vec3d a = mesh.vertices[std::size_t(tri[0])].cast<double>();
    const Vec3d b = mesh.vertices[std::size_t(tri[1])].cast<double>();
    const Vec3d c = mesh.vertices[std::size_t(tri[2])].cast<double>();
    const double expected = 0.5 * (b - a).cross(c - a).norm() * per_m2;
    std::size_t n = std::size_t(expected);
    if (unit(rng) < expected - double(n)) ++n;
    for (std::size_t i = 0; i < n; ++i) {
      double u = unit(rng), v = unit(rng);
      if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;  // fold into the triangle: uniform over its area
      samples.push_back(a + u * (b - a) + v * (c - a));
    }
  }
  return samples;
}

namespace {

/// The reachability grid: cells over the box, free when their centre keeps the clearance, and
/// reachable when 6-connected to the start through free cells.
class ReachGrid {
 public:
  ReachGrid(const World& world, const Eigen::AlignedBox3d& box, double cell_m, double clearance_m)
      : origin_(box.min()), cell_(cell_m) {
    for (int a = 0; a < 3; ++a) dim_[a] = std::max(1, int(std::floor(box.sizes()[a] / cell_m)));
    state_.assign(std::size_t(dim_[0]) * std::size_t(dim_[1]) * std::size_t(dim_[2]), kBlocked);
    tbb::parallel_for(tbb::blocked_range<int>(0, dim_[0]), [&](const tbb::blocked_range<int>& r) {
      for (int x = r.begin(); x != r.end(); ++x)
        for (int y = 0; y < dim_[1]; ++y)
          for (int z = 0; z < dim_[2]; ++z)
            if (world.isClear(centre(x, y, z), clearance_m)) state_[index(x, y, z)] = kFree;
    });
  }

  /// Floods from the cell of p; returns false when that cell is not free.
  bool flood(const Vec3d& p) {
    Eigen::Vector3i c;
    if (!cellOf(p, c) || state_[index(c[0], c[1], c[2])] != kFree) return false;
    std::deque<Eigen::Vector3i> queue{c};
    state_[index(c[0], c[1], c[2])] = kReachable;
    while (!queue.empty()) {
      const Eigen::Vector3i q = queue.front();
      queue.pop_front();
      for (int a = 0; a < 3; ++a)
        for (int s = -1; s <= 1; s += 2) {
          Eigen::Vector3i n = q;
          n[a] += s;
          if (n[a] < 0 || n[a] >= dim_[a]) continue;
          std::uint8_t& st = state_[index(n[0], n[1], n[2])];
          if (st != kFree) continue;
          st = kReachable;
          queue.push_back(n);
        }
    }
    return true;
  }

  bool reachable(const Vec3d& p) const {
    Eigen::Vector3i c;
    return cellOf(p, c) && state_[index(c[0], c[1], c[2])] == kReachable;
  }
  std::size_t cells() const { return state_.size(); }
  std::size_t count(std::uint8_t s) const { return std::size_t(std::count(state_.begin(), state_.end(), s)); }
  static constexpr std::uint8_t kBlocked = 0, kFree = 1, kReachable = 2;

 private:
  std::size_t index(int x, int y, int z) const {
    return (std::size_t(x) * std::size_t(dim_[1]) + std::size_t(y)) * std::size_t(dim_[2]) + std::size_t(z);
  }
  Vec3d centre(int x, int y, int z) const { return origin_ + cell_ * Vec3d(x + 0.5, y + 0.5, z + 0.5); }
  bool cellOf(const Vec3d& p, Eigen::Vector3i& c) const {
    for (int a = 0; a < 3; ++a) {
      const double f = std::floor((p[a] - origin_[a]) / cell_);
      if (!(f >= 0.0 && f < double(dim_[a]))) return false;
      c[a] = int(f);
    }
    return true;
  }

  Vec3d origin_;
  double cell_;
  Eigen::Vector3i dim_;
  std::vector<std::uint8_t> state_;
};

/// The fan of viewing directions (from a sample towards a camera) within the elevation band.
std::vector<Vec3d> viewDirections(const SurfaceCoverageConfig& c) {
  std::vector<Vec3d> dirs;
  for (int e = 0; e < c.elevation_steps; ++e) {
    const double elevation =
        c.elevation_steps == 1 ? 0.0 : -c.half_fov_vertical_rad + 2.0 * c.half_fov_vertical_rad * e / (c.elevation_steps - 1);
    for (int a = 0; a < c.azimuth_steps; ++a) {
      const double azimuth = 2.0 * M_PI * a / c.azimuth_steps;
      dirs.emplace_back(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                        std::sin(elevation));
    }
  }
  return dirs;
}

/// Offset of the ray origin from the sample along the direction, so the sample's own triangle is
/// not hit at t ~ 0.
constexpr double kRayOffset_m = 1e-3;

bool observable(const World& world, const ReachGrid& grid, const std::vector<Vec3d>& dirs, const Vec3d& s,
                const SurfaceCoverageConfig& c) {
  for (const Vec3d& d : dirs) {
    // Nearest reachable camera position along d; the segment to it must be clear. Clear segments
    // nest (a shorter one is part of a longer one), so the first reachable distance decides.
    for (double r = std::max(c.min_view_distance_m, c.grid_m); r <= c.max_view_distance_m + 1e-9; r += c.grid_m) {
      if (!grid.reachable(s + r * d)) continue;
      const RayHit hit = world.raycast(s + kRayOffset_m * d, d, r - kRayOffset_m);
      if (!hit.hit()) return true;
      break;  // blocked before the first reachable position: blocked for the farther ones too
    }
  }
  return false;
}
}  // namespace

ObservableSurface::ObservableSurface(const World& world, const Eigen::AlignedBox3d& box_W, const Vec3d& start_W,
                                     const SurfaceCoverageConfig& config)
    : config_(config) {
  config_.validate();
  if (box_W.isEmpty()) throw std::invalid_argument("ObservableSurface: the box is empty");
  const Stopwatch build;
  ReachGrid grid(world, box_W, config_.grid_m, config_.vehicle_clearance_m);
  if (!grid.flood(start_W))
    throw std::invalid_argument("ObservableSurface: the start is outside the box or within vehicle_clearance_m of a surface");
  stats_.grid_cells = grid.cells();
  stats_.reachable_cells = grid.count(ReachGrid::kReachable);

  std::vector<Vec3d> samples = sampleSurface(world.mesh(), config_.sample_spacing_m, config_.seed);
  stats_.samples_total = samples.size();
  samples.erase(std::remove_if(samples.begin(), samples.end(), [&](const Vec3d& p) { return !box_W.contains(p); }),
                samples.end());
  stats_.samples_in_box = samples.size();
  const std::vector<Vec3d> dirs = viewDirections(config_);
  std::vector<std::uint8_t> seen(samples.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, samples.size(), 256), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) seen[i] = observable(world, grid, dirs, samples[i], config_);
  });
  for (std::size_t i = 0; i < samples.size(); ++i)
    if (seen[i]) observable_.push_back(samples[i]);
  stats_.observable = observable_.size();
  stats_.observable_area_m2 = double(observable_.size()) * config_.sample_spacing_m * config_.sample_spacing_m;
  stats_.build_s = build.s();
}

std::vector<bool> ObservableSurface::known(const planner::MapQuery& map) const {
  const double s = map.voxelSize(), radius_m = config_.known_radius_vox * s;
  // The voxels whose centre a point of voxel c can lie within radius_m of (a point is at most half
  // a diagonal from c's centre), nearest first: a known one ends a point's search, and most
  // points are known. Which of them are within radius_m is decided per point, exactly.
  const int reach = int(std::ceil(config_.known_radius_vox)) + 1;
  // (with the per-point test's 1e-9 m slack, and 1e-6 voxels for the rounding of this bound)
  const double reach_vox = (radius_m + 1e-9) / s + 0.5 * std::sqrt(3.0) + 1e-6;
  std::vector<openvdb::Coord> near;
  for (int dx = -reach; dx <= reach; ++dx)
    for (int dy = -reach; dy <= reach; ++dy)
      for (int dz = -reach; dz <= reach; ++dz)
        if (dx * dx + dy * dy + dz * dz <= reach_vox * reach_vox) near.emplace_back(dx, dy, dz);
  std::stable_sort(near.begin(), near.end(), [](const openvdb::Coord& a, const openvdb::Coord& b) {
    return a.x() * a.x() + a.y() * a.y() + a.z() * a.z() < b.x() * b.x() + b.y() * b.y() + b.z() * b.z();
  });
  std::vector<std::uint8_t> flags(observable_.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, observable_.size(), 1024), [&](const tbb::blocked_range<std::size_t>& r) {
    const std::unique_ptr<planner::MapReader> reader = map.reader();
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const Vec3d& p = observable_[i];
      const openvdb::Coord c = map.worldToVoxel(p);
      for (const openvdb::Coord& d : near) {
        const openvdb::Coord n = c + d;
        if ((planner::voxelCenterOf(n, s) - p).norm() > radius_m + 1e-9) continue;
        if (reader->at(n) != planner::Occupancy::Unknown) {
          flags[i] = 1;
          break;
        }
      }
    }
  });
  return std::vector<bool>(flags.begin(), flags.end());
}

double ObservableSurface::coverage(const planner::MapQuery& map) const {
  if (observable_.empty()) return 0.0;
  const std::vector<bool> k = known(map);
  return double(std::count(k.begin(), k.end(), true)) / double(k.size());
}

}  // namespace vdbmap::sim
