#include "vdbmap/planner/map_query.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace vdbmap::planner {

namespace {
/// Half the diagonal of a voxel, in voxels: the farthest a point can be from its voxel's centre.
constexpr double kHalfDiagonalVox = 0.8660254037844386;
/// Largest clearance radius accepted, in voxels (the offset table grows with its cube).
constexpr double kMaxRadiusVox = 100.0;
}  // namespace

void MapReader::readBox(const openvdb::CoordBBox& box, Occupancy* out) {
  std::size_t i = 0;
  for (int x = box.min().x(); x <= box.max().x(); ++x)
    for (int y = box.min().y(); y <= box.max().y(); ++y)
      for (int z = box.min().z(); z <= box.max().z(); ++z) out[i++] = at(openvdb::Coord(x, y, z));
}

openvdb::Coord voxelOf(const Vec3d& p_W, double voxel_size_m) {
  const double inv = 1.0 / voxel_size_m;
  return openvdb::Coord(int(std::floor(p_W.x() * inv + 0.5)), int(std::floor(p_W.y() * inv + 0.5)),
                        int(std::floor(p_W.z() * inv + 0.5)));
}

openvdb::Coord MapQuery::worldToVoxel(const Vec3d& p_W) const { return voxelOf(p_W, voxelSize()); }

Vec3d MapQuery::voxelCenter(const openvdb::Coord& ijk) const { return voxelCenterOf(ijk, voxelSize()); }

openvdb::CoordBBox MapQuery::voxelsIn(const Eigen::AlignedBox3d& box_W) const {
  if (box_W.isEmpty()) return {};
  // Voxel i has its centre in [lo, hi] when ceil(lo / s) <= i <= floor(hi / s).
  const Vec3d lo = box_W.min() / voxelSize();
  const Vec3d hi = box_W.max() / voxelSize();
  return openvdb::CoordBBox(openvdb::Coord(int(std::ceil(lo.x())), int(std::ceil(lo.y())), int(std::ceil(lo.z()))),
                            openvdb::Coord(int(std::floor(hi.x())), int(std::floor(hi.y())), int(std::floor(hi.z()))));
}

Eigen::AlignedBox3d MapQuery::worldBox(const openvdb::CoordBBox& box) const {
  if (box.empty()) return Eigen::AlignedBox3d();  // Eigen's default box is empty
  return Eigen::AlignedBox3d(voxelCenter(box.min()) - Vec3d::Constant(0.5 * voxelSize()),
                             voxelCenter(box.max()) + Vec3d::Constant(0.5 * voxelSize()));
}

MapProbe::MapProbe(const MapQuery& map) : map_(&map), reader_(map.reader()), voxel_size_m_(map.voxelSize()) {}

void MapProbe::cacheBox(const openvdb::CoordBBox& box) {
  cache_box_ = box;
  if (box.empty()) {
    cache_.clear();
    return;
  }
  cache_dim_ = box.dim();
  cache_.resize(std::size_t(box.volume()));
  reader_->readBox(box, cache_.data());
}

const Occupancy* MapProbe::readRun(const openvdb::Coord& first, int axis, int n) {
  openvdb::Coord last = first;
  last[axis] += n - 1;
  run_.resize(std::size_t(n));
  if (cache_box_.isInside(first) && cache_box_.isInside(last)) {
    const std::size_t stride = axis == 2   ? 1
                               : axis == 1 ? std::size_t(cache_dim_.z())
                                           : std::size_t(cache_dim_.y()) * std::size_t(cache_dim_.z());
    const Occupancy* from = &cache_[boxIndex(cache_box_.min(), cache_dim_, first)];
    for (int i = 0; i < n; ++i) run_[std::size_t(i)] = from[std::size_t(i) * stride];
  } else {
    reader_->readBox(openvdb::CoordBBox(first, last), run_.data());
  }
  return run_.data();
}

const std::vector<MapProbe::Offset>& MapProbe::offsetsFor(double radius_m) {
  const double radius_vox = radius_m / voxel_size_m_;
  if (!(radius_vox >= 0.0) || radius_vox > kMaxRadiusVox)
    throw std::invalid_argument("MapProbe: radius_m = " + std::to_string(radius_m) + " must be in [0, " +
                                std::to_string(kMaxRadiusVox * voxel_size_m_) + "] (100 voxels)");
  const auto key = std::int64_t(std::llround(radius_vox * 1e6));
  auto it = offsets_.find(key);
  if (it != offsets_.end()) return it->second;

  const double reach = radius_vox + kHalfDiagonalVox;
  const int n = int(std::ceil(reach));
  std::vector<Offset> offsets;
  for (int x = -n; x <= n; ++x)
    for (int y = -n; y <= n; ++y)
      for (int z = -n; z <= n; ++z) {
        const double d = std::sqrt(double(x * x + y * y + z * z));
        if (d <= reach) offsets.push_back({openvdb::Coord(x, y, z), d});
      }
  std::sort(offsets.begin(), offsets.end(), [](const Offset& a, const Offset& b) {
    if (a.dist_vox != b.dist_vox) return a.dist_vox < b.dist_vox;
    return a.d < b.d;
  });
  return offsets_.emplace(key, std::move(offsets)).first->second;
}

bool MapProbe::isClear(const Vec3d& p_W, double radius_m) {
  const openvdb::Coord c = map_->worldToVoxel(p_W);
  const std::vector<Offset>& offsets = offsetsFor(radius_m);
  const Vec3d local = p_W / voxel_size_m_ - Vec3d(c.x(), c.y(), c.z());  // p in voxels from c's centre
  const double r_vox = radius_m / voxel_size_m_;
  const double r2 = r_vox * r_vox;
  const double surely_inside = r_vox - kHalfDiagonalVox;  // offsets this close are within reach of any p
  for (const Offset& o : offsets) {
    // The centre voxel (offset 0) is always checked: p itself must be in free space.
    if (o.dist_vox > surely_inside && o.dist_vox > 0.0) {
      const Vec3d d = Vec3d(o.d.x(), o.d.y(), o.d.z()) - local;
      if (d.squaredNorm() > r2) continue;
    }
    if (at(c + o.d) != Occupancy::Free) return false;
  }
  return true;
}

double MapProbe::clearance(const Vec3d& p_W, double max_m) {
  const openvdb::Coord c = map_->worldToVoxel(p_W);
  if (at(c) != Occupancy::Free) return 0.0;
  const std::vector<Offset>& offsets = offsetsFor(max_m);
  const Vec3d local = p_W / voxel_size_m_ - Vec3d(c.x(), c.y(), c.z());
  double best_vox = max_m / voxel_size_m_;
  for (const Offset& o : offsets) {
    // Offsets are sorted by |d|; a voxel centre is at least |d| - half diagonal from p.
    if (o.dist_vox - kHalfDiagonalVox > best_vox) break;
    if (at(c + o.d) == Occupancy::Free) continue;
    const double d = (Vec3d(o.d.x(), o.d.y(), o.d.z()) - local).norm();
    best_vox = std::min(best_vox, d);
  }
  return best_vox * voxel_size_m_;
}

template <typename OnVoxel>
bool MapProbe::traverse(const Vec3d& a_W, const Vec3d& b_W, OnVoxel&& on_voxel) const {
  // Amanatides-Woo traversal in the index space shifted by +0.5, where voxel (i, j, k) is the
  // unit cell [i, i+1) x [j, j+1) x [k, k+1).
  const Vec3d a = a_W / voxel_size_m_ + Vec3d::Constant(0.5);
  const Vec3d b = b_W / voxel_size_m_ + Vec3d::Constant(0.5);
  const Vec3d dir = b - a;
  int ijk[3], last[3], step[3];
  double t_max[3], t_delta[3];
  for (int k = 0; k < 3; ++k) {
    ijk[k] = int(std::floor(a[k]));
    last[k] = int(std::floor(b[k]));
    if (dir[k] > 0.0) {
      step[k] = 1;
      t_delta[k] = 1.0 / dir[k];
      t_max[k] = (std::floor(a[k]) + 1.0 - a[k]) * t_delta[k];
    } else if (dir[k] < 0.0) {
      step[k] = -1;
      t_delta[k] = -1.0 / dir[k];
      t_max[k] = (a[k] - std::floor(a[k])) * t_delta[k];
    } else {
      step[k] = 0;
      t_delta[k] = t_max[k] = std::numeric_limits<double>::infinity();
    }
  }
  // At most one voxel per crossed boundary plus the first: a hard bound against rounding.
  const int max_steps = std::abs(last[0] - ijk[0]) + std::abs(last[1] - ijk[1]) + std::abs(last[2] - ijk[2]) + 1;
  for (int n = 0; n < max_steps; ++n) {
    if (!on_voxel(openvdb::Coord(ijk[0], ijk[1], ijk[2]))) return false;
    if (ijk[0] == last[0] && ijk[1] == last[1] && ijk[2] == last[2]) return true;
    const int k = t_max[0] < t_max[1] ? (t_max[0] < t_max[2] ? 0 : 2) : (t_max[1] < t_max[2] ? 1 : 2);
    if (t_max[k] > 1.0) break;  // rounding: the end voxel is reached
    ijk[k] += step[k];
    t_max[k] += t_delta[k];
  }
  return on_voxel(openvdb::Coord(last[0], last[1], last[2]));
}

bool MapProbe::isVisible(const Vec3d& a_W, const Vec3d& b_W) {
  return traverse(a_W, b_W, [this](const openvdb::Coord& ijk) { return at(ijk) == Occupancy::Free; });
}

std::optional<openvdb::Coord> MapProbe::firstNotFree(const Vec3d& a_W, const Vec3d& b_W) {
  std::optional<openvdb::Coord> first;
  traverse(a_W, b_W, [&](const openvdb::Coord& ijk) {
    if (at(ijk) == Occupancy::Free) return true;
    first = ijk;
    return false;
  });
  return first;
}

bool MapProbe::isSegmentClear(const Vec3d& a_W, const Vec3d& b_W, double radius_m) {
  // Endpoints first (the usual reason for failure); they also validate the radius.
  if (!isClear(a_W, radius_m) || !isClear(b_W, radius_m)) return false;
  return isSegmentClearFromClearEnds(a_W, b_W, radius_m);
}

bool MapProbe::isSegmentClearFromClearEnds(const Vec3d& a_W, const Vec3d& b_W, double radius_m) {
  offsetsFor(radius_m);  // validates the radius
  const double r = radius_m / voxel_size_m_;
  // The voxels the segment crosses: a thin capsule may slip between voxel centres, so they count
  // too. Those of a capsule at least a voxel wide are within it (their centres are at most half a
  // diagonal off the segment) and the likeliest to be blocked: read first, they end most failing
  // tests early without changing any answer.
  if ((r < kHalfDiagonalVox || r >= 1.0) && !isVisible(a_W, b_W)) return false;
  // In voxel units voxel centres are the integer points.
  const Vec3d a = a_W / voxel_size_m_, b = b_W / voxel_size_m_, d = b - a;
  const double len2 = d.squaredNorm();
  if (len2 < 1e-18) return true;
  int k = 0;  // the main axis: every layer perpendicular to it meets the capsule in a small box
  for (int j = 1; j < 3; ++j)
    if (std::abs(d[j]) > std::abs(d[k])) k = j;
  // The layer's box is read in runs along v: along z (contiguous in blocks and caches) unless z is
  // the main axis. Which of the other two axes is u does not change the voxels visited.
  const int v = k == 2 ? 1 : 2, u = 3 - k - v;
  const double r2 = r * r;
  const int layer_lo = int(std::ceil(std::min(a[k], b[k]) - r)), layer_hi = int(std::floor(std::max(a[k], b[k]) + r));
  int c[3];
  for (int layer = layer_lo; layer <= layer_hi; ++layer) {
    // The part of the segment within r of this layer (in the k axis) bounds the other two axes.
    double t0 = (layer - r - a[k]) / d[k], t1 = (layer + r - a[k]) / d[k];
    if (t0 > t1) std::swap(t0, t1);
    t0 = std::clamp(t0, 0.0, 1.0);
    t1 = std::clamp(t1, 0.0, 1.0);
    const Vec3d p0 = a + d * t0, p1 = a + d * t1;
    const int u_lo = int(std::ceil(std::min(p0[u], p1[u]) - r)), u_hi = int(std::floor(std::max(p0[u], p1[u]) + r));
    const int v_lo = int(std::ceil(std::min(p0[v], p1[v]) - r)), v_hi = int(std::floor(std::max(p0[v], p1[v]) + r));
    if (v_lo > v_hi) continue;
    c[k] = layer;
    for (c[u] = u_lo; c[u] <= u_hi; ++c[u]) {
      c[v] = v_lo;
      const Occupancy* run = readRun(openvdb::Coord(c[0], c[1], c[2]), v, v_hi - v_lo + 1);
      // Only a voxel that is not free can fail the test; whether its centre is within r of the
      // segment is asked of those alone.
      for (int i = 0; i <= v_hi - v_lo; ++i) {
        if (run[i] == Occupancy::Free) continue;
        c[v] = v_lo + i;
        const Vec3d centre(c[0], c[1], c[2]);
        const double t = std::clamp((centre - a).dot(d) / len2, 0.0, 1.0);
        if ((a + d * t - centre).squaredNorm() <= r2) return false;
      }
    }
  }
  return true;
}

}  // namespace vdbmap::planner
