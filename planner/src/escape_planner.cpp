#include "vdbmap/planner/escape_planner.hpp"

#include "vdbmap/field_check.hpp"
#include "vdbmap/planner/assume_free_map.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace vdbmap::planner {
namespace {
/// A box around each segment of `way`, grown by `grow_m`: where an escape's trajectory may pass
/// voxels that blocked its start (AssumeFreeMap with occupied_too).
std::vector<Eigen::AlignedBox3d> corridorAround(const std::vector<Vec3d>& way, double grow_m) {
  std::vector<Eigen::AlignedBox3d> boxes;
  const Vec3d grow = Vec3d::Constant(grow_m);
  for (std::size_t k = 1; k < way.size(); ++k)
    boxes.emplace_back(way[k - 1].cwiseMin(way[k]) - grow, way[k - 1].cwiseMax(way[k]) + grow);
  return boxes;
}
}  // namespace

void EscapeConfig::validate() const {
  const FieldCheck check("EscapeConfig");
  if (bounds_W && (bounds_W->isEmpty() || !bounds_W->min().allFinite() || !bounds_W->max().allFinite()))
    check.fail("bounds_W", "non-empty finite boxes");
  check.inRange("clearance_m", clearance_m, 0.0, 10.0);
  if (flown_positions_kept < 1 || flown_positions_kept > 1000000) check.fail("flown_positions_kept", "[1, 1e6]");
  check.inRange("retreat_reach_m", retreat_reach_m, 0.0, 100.0);
  if (!(escape_reach_m > 0.0 && escape_reach_m <= 10.0)) check.fail("escape_reach_m", "(0, 10]", escape_reach_m);
  trajectory.validate();
}

EscapePlanner::EscapePlanner(const EscapeConfig& params) : params_(params) { params_.validate(); }

void EscapePlanner::recordFlown(const Vec3d& p_W, double stamp_s, double voxel_m) {
  if (!flown_.empty() && (p_W - flown_.back().p_W).norm() < voxel_m) return;
  flown_.push_back({p_W, stamp_s});
  if (flown_.size() > std::size_t(params_.flown_positions_kept)) flown_.pop_front();
}

void EscapePlanner::shiftFrame(const Eigen::Isometry3d& shift) {
  for (Flown& f : flown_) f.p_W = shift * f.p_W;
}

void EscapePlanner::correctHistory(const std::function<FlatPose(const FlownViewpoint&)>& corrected) {
  std::vector<Vec3d> moved;
  moved.reserve(flown_.size());
  for (const Flown& f : flown_) {
    const Vec3d p_W = corrected(FlownViewpoint{f.p_W, 0.0, f.stamp_s}).position_W;
    if (!p_W.allFinite())
      throw std::invalid_argument("EscapePlanner::correctHistory: non-finite corrected position for t = " +
                                  std::to_string(f.stamp_s));
    moved.push_back(p_W);
  }
  for (std::size_t i = 0; i < flown_.size(); ++i) flown_[i].p_W = moved[i];
}

std::optional<Trajectory> EscapePlanner::retreat(const MapQuery& map, const VehicleState& vehicle, bool farthest,
                                                 const RetreatCheck& accept, double flown_since_s) {
  const double vs = map.voxelSize(), r = params_.clearance_m;
  MapProbe probe(map);
  std::vector<Vec3d> way{vehicle.position_W};
  double length = 0.0;
  std::size_t keep = 0;     // flown positions left once back at the end: those flown before it
  std::size_t way_end = 0;  // the end's index in `way`
  for (std::size_t i = flown_.size(); i-- > 0;) {
    if (flown_[i].stamp_s < flown_since_s) break;
    const Vec3d& q = flown_[i].p_W;
    const double step = (q - way.back()).norm();
    if (length + step > params_.retreat_reach_m) break;
    if (step < 1e-3) continue;
    length += step;
    way.push_back(q);
    if (length >= vs && inBounds(q) && probe.isClear(q, r)) {
      keep = i + 1;
      way_end = way.size() - 1;
      if (!farthest) break;
    }
  }
  if (keep == 0) return std::nullopt;
  way.resize(way_end + 1);
  const AssumeFreeMap corridor_map(map, corridorAround(way, r + vs), /*occupied_too=*/true);
  // From rest: a lead-in along the current velocity would first fly on toward what blocked it.
  VehicleState at_rest = vehicle;
  at_rest.velocity_W.setZero();
  TrajectoryResult traj = planTrajectory(way, at_rest, vehicle.yaw_rad, corridor_map, params_.trajectory);
  if (!traj.ok() || (accept && !accept(traj.trajectory, way))) return std::nullopt;
  flown_.resize(keep);
  return std::move(traj.trajectory);
}

std::optional<Trajectory> EscapePlanner::straightEscape(const MapQuery& map, const VehicleState& vehicle) const {
  const double vs = map.voxelSize(), r = params_.clearance_m;
  const Vec3d& p = vehicle.position_W;
  MapProbe probe(map);

  // Away from the occupied voxels within the clearance (+ a voxel for their extent).
  Vec3d away = Vec3d::Zero();
  const int n = int(std::ceil((r + vs) / vs));
  const openvdb::Coord c = map.worldToVoxel(p);
  for (int dx = -n; dx <= n; ++dx)
    for (int dy = -n; dy <= n; ++dy)
      for (int dz = -n; dz <= n; ++dz) {
        const openvdb::Coord v = c.offsetBy(dx, dy, dz);
        const Vec3d d = p - map.voxelCenter(v);
        if (d.norm() > r + vs || probe.at(v) != Occupancy::Occupied) continue;
        away += d.norm() > 1e-9 ? Vec3d(d.normalized()) : Vec3d::Zero();
      }
  // Candidate directions: away first, then the 26 grid directions most aligned with it.
  const Vec3d a = away.norm() > 1e-9 ? Vec3d(away.normalized()) : Vec3d::Zero();
  std::vector<Vec3d> dirs;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z)
        if (x || y || z) dirs.push_back(Vec3d(x, y, z).normalized());
  std::stable_sort(dirs.begin(), dirs.end(), [&a](const Vec3d& u, const Vec3d& w) { return u.dot(a) > w.dot(a); });
  if (!a.isZero()) dirs.insert(dirs.begin(), a);

  // The nearest clear point (preferring the away direction) whose straight way crosses no
  // occupied voxel beyond the vehicle's own.
  const auto wayFree = [&](const Vec3d& q) {
    const double len = (q - p).norm();
    for (double t = 0.5 * vs; t <= len; t += 0.5 * vs)
      if (probe.atWorld(p + (q - p) * (t / len)) == Occupancy::Occupied) return false;
    return true;
  };
  for (double d = vs; d <= params_.escape_reach_m + 1e-9; d += vs) {
    for (const Vec3d& u : dirs) {
      const Vec3d q = p + u * d;
      if (!inBounds(q) || !probe.isClear(q, r) || !wayFree(q)) continue;
      // The move was checked here: let the trajectory pass the voxels near the start.
      const AssumeFreeMap escape_map(map, corridorAround({p, q}, r + vs), /*occupied_too=*/true);
      TrajectoryResult traj = planTrajectory({p, q}, vehicle, vehicle.yaw_rad, escape_map, params_.trajectory);
      if (traj.ok()) return std::move(traj.trajectory);
    }
  }
  return std::nullopt;
}

}  // namespace vdbmap::planner
