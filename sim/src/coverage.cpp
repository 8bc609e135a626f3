#include "vdbmap/sim/coverage.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <stdexcept>
#include <string>

namespace vdbmap::sim {

void CoverageConfig::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("CoverageConfig." + what); };
  limits.validate();
  if (!std::isfinite(altitude_m)) fail("altitude_m must be finite");
  if (!(clearance_m > 0.0 && clearance_m <= 10.0)) fail("clearance_m must be in (0, 10]");
  if (!(grid_cell_m > 0.0 && grid_cell_m <= clearance_m)) fail("grid_cell_m must be in (0, clearance_m]");
  if (!(lane_spacing_m >= grid_cell_m && lane_spacing_m <= 1000.0))
    fail("lane_spacing_m must be in [grid_cell_m, 1000]");
  if (!(target_spacing_m >= grid_cell_m && target_spacing_m <= 1000.0))
    fail("target_spacing_m must be in [grid_cell_m, 1000]");
  if (!(lane_change_penalty_m >= 0.0 && lane_change_penalty_m <= 1000.0))
    fail("lane_change_penalty_m must be in [0, 1000]");
  if (!(sweep_amplitude_rad >= 0.0 && sweep_amplitude_rad <= M_PI)) fail("sweep_amplitude_rad must be in [0, pi]");
  if (!(sweep_leg_m > 0.0 && sweep_leg_m <= 1000.0)) fail("sweep_leg_m must be in (0, 1000]");
  if (!(return_every_m >= 0.0 && return_every_m <= 1e6)) fail("return_every_m must be in [0, 1e6]");
  if (!std::isfinite(start_yaw)) fail("start_yaw must be finite");
  if (!(dt_s > 0.0 && dt_s <= 1.0)) fail("dt_s must be in (0, 1]");
}

namespace {
/// The planning grid at the flight altitude; cells are indexed along (a) and across (b) the lanes.
class Grid {
 public:
  Grid(const World& world, const CoverageConfig& c) : cell_(c.grid_cell_m), z_(c.altitude_m) {
    const Eigen::AlignedBox3d& box = world.bounds();
    origin_ = box.min().head<2>();
    const Eigen::Vector2d extent = box.max().head<2>() - origin_;
    along_x_ = extent.x() >= extent.y();
    nx_ = std::max(1, int(std::ceil(extent.x() / cell_)));
    ny_ = std::max(1, int(std::ceil(extent.y() / cell_)));
    free_.assign(std::size_t(nx_) * std::size_t(ny_), 0);
    // Clearance plus half the cell diagonal: a straight move between neighbouring free centres
    // stays within that half diagonal of one of them, so it keeps the clearance.
    const double r = c.clearance_m + 0.5 * std::sqrt(2.0) * cell_;
    tbb::parallel_for(tbb::blocked_range<int>(0, ny_), [&](const tbb::blocked_range<int>& rows) {
      for (int j = rows.begin(); j != rows.end(); ++j)
        for (int i = 0; i < nx_; ++i) free_[index(i, j)] = world.isClear(centre(i, j), r) ? 1 : 0;
    });
  }
  int nx() const { return nx_; }
  int ny() const { return ny_; }
  std::size_t size() const { return free_.size(); }
  std::size_t index(int i, int j) const { return std::size_t(j) * std::size_t(nx_) + std::size_t(i); }
  int i(std::size_t k) const { return int(k % std::size_t(nx_)); }
  int j(std::size_t k) const { return int(k / std::size_t(nx_)); }
  bool inside(int i, int j) const { return i >= 0 && j >= 0 && i < nx_ && j < ny_; }
  bool free(std::size_t k) const { return free_[k] != 0; }
  Vec3d centre(int i, int j) const { return {origin_.x() + (i + 0.5) * cell_, origin_.y() + (j + 0.5) * cell_, z_}; }
  Vec3d centre(std::size_t k) const { return centre(i(k), j(k)); }
  /// Lanes run along the longer axis: (along, across) coordinates of a cell.
  int along(std::size_t k) const { return along_x_ ? i(k) : j(k); }
  int across(std::size_t k) const { return along_x_ ? j(k) : i(k); }
  std::size_t fromLane(int along, int across) const { return along_x_ ? index(along, across) : index(across, along); }
  int alongCount() const { return along_x_ ? nx_ : ny_; }
  double cell() const { return cell_; }
  std::size_t nearest(const Eigen::Vector2d& xy) const {
    const int i = std::clamp(int(std::floor((xy.x() - origin_.x()) / cell_)), 0, nx_ - 1);
    const int j = std::clamp(int(std::floor((xy.y() - origin_.y()) / cell_)), 0, ny_ - 1);
    return index(i, j);
  }

  /// Neighbours (8-connected) with the length of the move.
  template <typename Fn>
  void forNeighbours(std::size_t k, Fn&& fn) const {
    const int ci = i(k), cj = j(k);
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di) {
        if ((di == 0 && dj == 0) || !inside(ci + di, cj + dj)) continue;
        const std::size_t n = index(ci + di, cj + dj);
        if (free(n)) fn(n, (di != 0 && dj != 0) ? std::sqrt(2.0) * cell_ : cell_);
      }
  }

 private:
  double cell_, z_;
  Eigen::Vector2d origin_;
  bool along_x_ = true;
  int nx_ = 0, ny_ = 0;
  std::vector<std::uint8_t> free_;
};

/// Shortest grid paths from one cell to all reachable cells.
struct Dijkstra {
  std::vector<double> dist;
  std::vector<std::size_t> parent;

  Dijkstra(const Grid& g, std::size_t source)
      : dist(g.size(), std::numeric_limits<double>::infinity()), parent(g.size(), source) {
    using Item = std::pair<double, std::size_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> open;
    dist[source] = 0.0;
    open.push({0.0, source});
    while (!open.empty()) {
      const auto [d, k] = open.top();
      open.pop();
      if (d > dist[k]) continue;
      g.forNeighbours(k, [&](std::size_t n, double step) {
        if (d + step < dist[n]) {
          dist[n] = d + step;
          parent[n] = k;
          open.push({dist[n], n});
        }
      });
    }
  }
  std::vector<std::size_t> pathTo(std::size_t target) const {
    std::vector<std::size_t> path{target};
    while (parent[path.back()] != path.back()) path.push_back(parent[path.back()]);
    std::reverse(path.begin(), path.end());
    return path;
  }
};

struct Target {
  std::size_t cell;
  int lane;
  bool visited = false;
};

/// Targets along lanes of reachable cells, spread evenly over each run.
std::vector<Target> laneTargets(const Grid& g, const std::vector<bool>& reachable, const CoverageConfig& c) {
  int lo = std::numeric_limits<int>::max(), hi = std::numeric_limits<int>::min();
  for (std::size_t k = 0; k < g.size(); ++k)
    if (reachable[k]) lo = std::min(lo, g.across(k)), hi = std::max(hi, g.across(k));
  const int step = std::max(1, int(std::lround(c.lane_spacing_m / g.cell())));
  const int lanes = (hi - lo) / step + 1;
  const int first = lo + ((hi - lo) - (lanes - 1) * step) / 2;  // centre the lanes
  std::vector<Target> targets;
  for (int lane = 0; lane < lanes; ++lane) {
    const int b = first + lane * step;
    for (int a = 0; a < g.alongCount();) {
      if (!reachable[g.fromLane(a, b)]) {
        ++a;
        continue;
      }
      int end = a;
      while (end + 1 < g.alongCount() && reachable[g.fromLane(end + 1, b)]) ++end;
      const double run_m = double(end - a + 1) * g.cell();
      const int n = std::max(1, int(std::ceil(run_m / c.target_spacing_m - 1e-9)));
      for (int t = 0; t < n; ++t) {
        const int at = a + int(std::floor((t + 0.5) * double(end - a + 1) / n));
        targets.push_back({g.fromLane(std::min(at, end), b), lane});
      }
      a = end + 1;
    }
  }
  return targets;
}

/// Line-of-sight shortening of a grid path: from each kept point, the farthest later point the
/// vehicle reaches in a straight line with the clearance (scanning ahead in strides of 4 cells).
std::vector<Vec3d> shorten(const World& world, const std::vector<Vec3d>& path, double clearance) {
  std::vector<Vec3d> out{path.front()};
  std::size_t k = 0;
  while (k + 1 < path.size()) {
    std::size_t best = k + 1;  // neighbouring cells are always reachable in a straight line
    for (std::size_t j = std::min(path.size() - 1, k + 4);; j = std::min(path.size() - 1, j + 4)) {
      if (!world.isSegmentClear(path[k], path[j], clearance)) break;
      best = j;
      if (j == path.size() - 1) break;
    }
    out.push_back(path[best]);
    k = best;
  }
  return out;
}

/// Stop-and-go waypoints with yaw sweeps along the polyline, after a full turn at its start.
std::vector<FlatPose> withYaw(const std::vector<Vec3d>& polyline, const CoverageConfig& c) {
  std::vector<FlatPose> out;
  double yaw = c.start_yaw;
  out.push_back({polyline.front(), yaw});
  auto spin = [&](const Vec3d& p) {
    for (int q = 1; q <= 3; ++q) out.push_back({p, yaw + q * 2.0 * M_PI / 3.0});
    yaw += 2.0 * M_PI;
  };
  if (c.spin_at_start) spin(polyline.front());
  double side = 1.0;
  for (std::size_t k = 1; k < polyline.size(); ++k) {
    const Vec3d d = polyline[k] - polyline[k - 1];
    const double length = d.norm();
    if (length < 1e-9) continue;
    const double heading = std::atan2(d.y(), d.x());
    const int legs = std::max(1, int(std::ceil(length / c.sweep_leg_m - 1e-9)));
    for (int l = 1; l <= legs; ++l) {
      yaw += angleDifference(heading + side * c.sweep_amplitude_rad, yaw);
      if (c.sweep_amplitude_rad > 0.0) side = -side;
      out.push_back({polyline[k - 1] + d * (double(l) / legs), yaw});
    }
  }
  return out;
}
}  // namespace

CoveragePlan planCoverage(const World& world, const CoverageConfig& config) {
  config.validate();
  const Grid grid(world, config);
  CoveragePlan plan;
  for (std::size_t k = 0; k < grid.size(); ++k) plan.free_cells += grid.free(k) ? 1 : 0;
  if (plan.free_cells == 0)
    throw std::invalid_argument("planCoverage: no free cell at altitude " + std::to_string(config.altitude_m) + " m");

  // The start: given, or the free cell nearest the centre of the world's box.
  std::size_t start = 0;
  if (config.start_xy.allFinite()) {
    start = grid.nearest(config.start_xy);
    if (!grid.free(start)) throw std::invalid_argument("planCoverage: the start is within the clearance of the world");
  } else {
    const Vec3d c = world.bounds().center();
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < grid.size(); ++k) {
      const double d = (grid.centre(k).head<2>() - c.head<2>()).squaredNorm();
      if (grid.free(k) && d < best) best = d, start = k;
    }
  }
  const Dijkstra from_start(grid, start);
  std::vector<bool> reachable(grid.size(), false);
  for (std::size_t k = 0; k < grid.size(); ++k) reachable[k] = std::isfinite(from_start.dist[k]);
  plan.reachable_cells = std::size_t(std::count(reachable.begin(), reachable.end(), true));
  plan.start_W = grid.centre(start);

  // Greedy tour over the lane targets, then home.
  std::vector<Target> targets = laneTargets(grid, reachable, config);
  std::vector<Vec3d> polyline{plan.start_W};
  std::size_t here = start;
  int lane = -1;
  double since_start_m = 0.0;  // path length since the last pass through the start
  auto travel = [&](const Dijkstra& paths, std::size_t to) {
    since_start_m += paths.dist[to];
    std::vector<Vec3d> cells;
    for (const std::size_t k : paths.pathTo(to)) cells.push_back(grid.centre(k));
    const std::vector<Vec3d> leg = cells.size() > 1 ? shorten(world, cells, config.clearance_m) : cells;
    polyline.insert(polyline.end(), leg.begin() + 1, leg.end());
    here = to;
  };
  for (std::size_t visited = 0; visited < targets.size(); ++visited) {
    const Dijkstra paths(grid, here);
    std::size_t next = targets.size();
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t t = 0; t < targets.size(); ++t) {
      if (targets[t].visited) continue;
      const double cost = paths.dist[targets[t].cell] +
                          (lane < 0 ? 0.0 : config.lane_change_penalty_m * std::abs(targets[t].lane - lane));
      if (cost < best) best = cost, next = t;
    }
    targets[next].visited = true;
    lane = targets[next].lane;
    plan.targets.push_back(grid.centre(targets[next].cell));
    travel(paths, targets[next].cell);
    // Back through the start now and then: the start was seen all round, so every pass closes
    // a loop there.
    if (config.return_every_m > 0.0 && since_start_m >= config.return_every_m && visited + 1 < targets.size()) {
      travel(Dijkstra(grid, here), start);
      since_start_m = 0.0;
      ++plan.returns;
    }
  }
  if (here != start) travel(Dijkstra(grid, here), start);

  plan.waypoints = withYaw(polyline, config);
  plan.trajectory = timeParametrize(plan.waypoints, config.limits, config.dt_s, 0.0, /*shortest_yaw=*/false);
  return plan;
}

}  // namespace vdbmap::sim
