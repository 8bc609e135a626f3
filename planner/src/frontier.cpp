#include "vdbmap/planner/frontier.hpp"

#include <Eigen/Eigenvalues>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace vdbmap::planner {

namespace {

const openvdb::Coord kFaceNeighbours[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};

/// The 26 neighbours of a voxel (faces, edges, corners).
std::vector<openvdb::Coord> allNeighbours() {
  std::vector<openvdb::Coord> n;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z)
        if (x || y || z) n.emplace_back(x, y, z);
  return n;
}
const std::vector<openvdb::Coord> kAllNeighbours = allNeighbours();

bool overlaps(const openvdb::CoordBBox& a, const openvdb::CoordBBox& b) { return !a.empty() && !b.empty() && a.hasOverlap(b); }

/// Floor division that rounds toward -infinity for negative coordinates too.
int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

Vec3d centreOf(const std::vector<openvdb::Coord>& voxels, double voxel_size_m) {
  Vec3d sum = Vec3d::Zero();
  for (const openvdb::Coord& c : voxels) sum += Vec3d(c.x(), c.y(), c.z());
  return sum / double(voxels.size()) * voxel_size_m;
}

/// FUEL's horizontal split: while some voxel is farther than `radius_m` from the centroid in x-y,
/// split along the principal axis of the x-y spread (voxels on the positive side, or on the axis'
/// normal line, go first). Pieces keep the sorted order of `voxels`.
void splitHorizontally(const std::vector<openvdb::Coord>& voxels, double voxel_size_m, double radius_m,
                       std::vector<std::vector<openvdb::Coord>>& out) {
  const Vec3d mean = centreOf(voxels, voxel_size_m);
  const double r2 = radius_m * radius_m;
  bool too_wide = false;
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const openvdb::Coord& c : voxels) {
    const Eigen::Vector2d d = Eigen::Vector2d(c.x(), c.y()) * voxel_size_m - mean.head<2>();
    too_wide = too_wide || d.squaredNorm() > r2;
    cov += d * d.transpose();
  }
  if (!too_wide) {
    out.push_back(voxels);
    return;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov / double(voxels.size()));
  Eigen::Vector2d axis = eig.eigenvectors().col(1);  // eigenvalues ascend: the last is the largest
  // The eigenvector's sign is arbitrary; fix it so the split does not depend on the solver.
  if (axis.x() < 0.0 || (axis.x() == 0.0 && axis.y() < 0.0)) axis = -axis;
  std::vector<openvdb::Coord> positive, negative;
  for (const openvdb::Coord& c : voxels) {
    const Eigen::Vector2d d = Eigen::Vector2d(c.x(), c.y()) * voxel_size_m - mean.head<2>();
    (d.dot(axis) >= 0.0 ? positive : negative).push_back(c);
  }
  if (positive.empty() || negative.empty()) {  // cannot happen for a wide set; never loop forever
    out.push_back(voxels);
    return;
  }
  splitHorizontally(positive, voxel_size_m, radius_m, out);
  splitHorizontally(negative, voxel_size_m, radius_m, out);
}

/// One voxel per stride^3 cube: the voxel nearest the mean of the cube's voxels.
std::vector<openvdb::Coord> sampleVoxels(const std::vector<openvdb::Coord>& voxels, int stride) {
  std::map<openvdb::Coord, std::vector<openvdb::Coord>> cubes;
  for (const openvdb::Coord& c : voxels)
    cubes[openvdb::Coord(floorDiv(c.x(), stride), floorDiv(c.y(), stride), floorDiv(c.z(), stride))].push_back(c);
  std::vector<openvdb::Coord> samples;
  samples.reserve(cubes.size());
  for (const auto& [cube, members] : cubes) {
    const Vec3d mean = centreOf(members, 1.0);
    const openvdb::Coord* best = &members.front();
    double best_d2 = 1e300;
    for (const openvdb::Coord& c : members) {
      const double d2 = (Vec3d(c.x(), c.y(), c.z()) - mean).squaredNorm();
      if (d2 < best_d2) {
        best_d2 = d2;
        best = &c;
      }
    }
    samples.push_back(*best);
  }
  std::sort(samples.begin(), samples.end());
  return samples;
}

}  // namespace

void FrontierParams::validate() const {
  auto fail = [](const std::string& field, const std::string& range) {
    throw std::invalid_argument("FrontierParams." + field + " must be in " + range);
  };
  if (min_cluster_size < 1 || min_cluster_size > 100000000) fail("min_cluster_size", "[1, 1e8]");
  if (!(split_radius_xy_m > 0.0 && split_radius_xy_m <= 1e4)) fail("split_radius_xy_m", "(0, 1e4]");
  if (sample_stride_vox < 1 || sample_stride_vox > 64) fail("sample_stride_vox", "[1, 64]");
  if (bounds_W && (bounds_W->isEmpty() || !bounds_W->min().allFinite() || !bounds_W->max().allFinite()))
    fail("bounds_W", "non-empty finite boxes");
}

bool isFrontierVoxel(MapReader& reader, const openvdb::Coord& ijk, const openvdb::CoordBBox* bounds) {
  const bool bounded = bounds && !bounds->empty();
  if (bounded && !bounds->isInside(ijk)) return false;
  if (reader.at(ijk) != Occupancy::Free) return false;
  for (const openvdb::Coord& d : kFaceNeighbours) {
    const openvdb::Coord n = ijk + d;
    if (bounded && !bounds->isInside(n)) continue;
    if (reader.at(n) == Occupancy::Unknown) return true;
  }
  return false;
}

std::size_t FrontierMap::CoordHash::operator()(const openvdb::Coord& c) const noexcept {
  std::uint64_t h = std::uint64_t(std::uint32_t(c.x())) * 0x9E3779B97F4A7C15ULL;
  h ^= std::uint64_t(std::uint32_t(c.y())) * 0xC2B2AE3D27D4EB4FULL + (h << 6) + (h >> 2);
  h ^= std::uint64_t(std::uint32_t(c.z())) * 0x165667B19E3779F9ULL + (h << 6) + (h >> 2);
  return std::size_t(h ^ (h >> 31));
}

FrontierMap::FrontierMap(const FrontierParams& params) : params_(params) { params_.validate(); }

const FrontierCluster* FrontierMap::find(ClusterId id) const {
  const auto it = std::lower_bound(clusters_.begin(), clusters_.end(), id,
                                   [](const FrontierCluster& c, ClusterId v) { return c.id < v; });
  return it != clusters_.end() && it->id == id ? &*it : nullptr;
}

void FrontierMap::checkVoxelSize(const MapQuery& map) {
  if (voxel_size_m_ == 0.0) voxel_size_m_ = map.voxelSize();
  if (map.voxelSize() != voxel_size_m_)
    throw std::invalid_argument("FrontierMap: the map's voxel size changed from " + std::to_string(voxel_size_m_) +
                                " to " + std::to_string(map.voxelSize()) + " m; call rebuild() with a new FrontierMap");
}

openvdb::CoordBBox FrontierMap::boundsIndex(const MapQuery& map) const {
  return params_.bounds_W ? map.voxelsIn(*params_.bounds_W) : openvdb::CoordBBox();
}

std::vector<openvdb::Coord> FrontierMap::scanFrontiers(const MapQuery& map, const openvdb::CoordBBox& box) const {
  if (box.empty()) return {};
  const openvdb::CoordBBox bounds = boundsIndex(map);
  const openvdb::CoordBBox* bounds_ptr = params_.bounds_W ? &bounds : nullptr;
  // One x-slab per task, each with its own reader; slabs are concatenated in order, so the
  // result does not depend on the thread count.
  const int x0 = box.min().x();
  const int slabs = box.dim().x();
  std::vector<std::vector<openvdb::Coord>> found(static_cast<std::size_t>(slabs));
  tbb::parallel_for(tbb::blocked_range<int>(0, slabs, 4), [&](const tbb::blocked_range<int>& r) {
    std::unique_ptr<MapReader> reader = map.reader();
    for (int i = r.begin(); i < r.end(); ++i) {
      const int x = x0 + i;
      for (int y = box.min().y(); y <= box.max().y(); ++y)
        for (int z = box.min().z(); z <= box.max().z(); ++z) {
          const openvdb::Coord c(x, y, z);
          if (isFrontierVoxel(*reader, c, bounds_ptr)) found[std::size_t(i)].push_back(c);
        }
    }
  });
  std::vector<openvdb::Coord> all;
  for (auto& f : found) all.insert(all.end(), f.begin(), f.end());
  return all;
}

void FrontierMap::floodComponents(std::vector<openvdb::Coord> pending) {
  // Pending voxels are in owner_ with component 0 ("unassigned"); flood 26-connected components
  // over them, seeded in sorted order so that the result is deterministic.
  std::sort(pending.begin(), pending.end());
  for (const openvdb::Coord& c : pending) owner_[c] = 0;
  std::vector<openvdb::Coord> stack;
  for (const openvdb::Coord& seed : pending) {
    if (owner_[seed] != 0) continue;
    const ComponentId id = next_component_++;
    std::vector<openvdb::Coord> voxels;
    owner_[seed] = id;
    stack.assign(1, seed);
    while (!stack.empty()) {
      const openvdb::Coord c = stack.back();
      stack.pop_back();
      voxels.push_back(c);
      for (const openvdb::Coord& d : kAllNeighbours) {
        const auto it = owner_.find(c + d);
        // A neighbour owned by another component would mean an untouched component is adjacent
        // to a changed voxel, which the dirty-region argument (see the header) rules out.
        if (it == owner_.end() || it->second != 0) continue;
        it->second = id;
        stack.push_back(it->first);
      }
    }
    std::sort(voxels.begin(), voxels.end());
    Component comp;
    for (const openvdb::Coord& c : voxels) comp.bbox.expand(c);
    comp.voxels = std::move(voxels);
    components_.emplace(id, std::move(comp));
  }
}

std::vector<ClusterId> FrontierMap::makeClusters(const MapQuery& map, const std::vector<openvdb::Coord>& voxels,
                                                 ReusableClusters* reusable, std::vector<ClusterId>* added) {
  std::vector<ClusterId> ids;
  if (int(voxels.size()) < params_.min_cluster_size) return ids;
  std::vector<std::vector<openvdb::Coord>> pieces;
  splitHorizontally(voxels, map.voxelSize(), params_.split_radius_xy_m, pieces);
  for (auto& piece : pieces) {
    // A piece identical to a cluster being taken apart is that cluster: keep its id (and data).
    if (reusable) {
      const auto it = reusable->find(piece.front());
      if (it != reusable->end()) {
        auto same = std::find_if(it->second.begin(), it->second.end(),
                                 [&](ClusterId id) { return id != 0 && find(id)->voxels == piece; });
        if (same != it->second.end()) {
          ids.push_back(*same);
          *same = 0;  // taken
          continue;
        }
      }
    }
    FrontierCluster c;
    c.id = next_cluster_++;
    c.centroid_W = centreOf(piece, map.voxelSize());
    for (const openvdb::Coord& v : piece) c.bbox.expand(v);
    c.samples = sampleVoxels(piece, params_.sample_stride_vox);
    c.voxels = std::move(piece);
    ids.push_back(c.id);
    if (added) added->push_back(c.id);
    clusters_.push_back(std::move(c));  // ids grow, so clusters_ stays sorted
  }
  return ids;
}

FrontierUpdate FrontierMap::rebuild(const MapQuery& map) {
  FrontierUpdate update;
  for (const FrontierCluster& c : clusters_) update.removed.push_back(c.id);
  owner_.clear();
  components_.clear();
  clusters_.clear();
  voxel_size_m_ = 0.0;
  checkVoxelSize(map);
  openvdb::CoordBBox box = map.knownBounds();
  if (!box.empty()) {
    box = box.expandBy(1);
    if (params_.bounds_W) box.intersect(boundsIndex(map));
  }
  std::vector<openvdb::Coord> found = scanFrontiers(map, box);
  update.voxels_scanned = box.empty() ? 0 : std::size_t(box.volume());
  const std::size_t first = next_component_;
  floodComponents(std::move(found));
  for (auto it = components_.lower_bound(first); it != components_.end(); ++it) {
    it->second.clusters = makeClusters(map, it->second.voxels, nullptr, &update.added);
  }
  update.components_reflooded = components_.size();
  update.frontier_voxels = owner_.size();
  return update;
}

FrontierUpdate FrontierMap::update(const MapQuery& map, const openvdb::CoordBBox& dirty) {
  FrontierUpdate update;
  checkVoxelSize(map);
  if (dirty.empty()) {
    update.frontier_voxels = owner_.size();
    return update;
  }
  // Voxels whose status may have changed, and the region whose components may have changed.
  openvdb::CoordBBox scan = dirty.expandBy(1);
  if (params_.bounds_W) scan.intersect(boundsIndex(map));
  const openvdb::CoordBBox reach = dirty.expandBy(2);

  // Components touching the reach are taken apart; their voxels outside the scan keep their
  // status and are flooded again together with the new frontier voxels of the scan.
  std::vector<openvdb::Coord> pending;
  std::vector<ComponentId> removed;
  ReusableClusters reusable;  // the taken-apart clusters, by first voxel
  for (const auto& [id, comp] : components_) {
    if (!overlaps(comp.bbox, reach)) continue;
    if (std::none_of(comp.voxels.begin(), comp.voxels.end(), [&](const openvdb::Coord& c) { return reach.isInside(c); }))
      continue;
    removed.push_back(id);
    for (const ClusterId cid : comp.clusters) reusable[find(cid)->voxels.front()].push_back(cid);
  }
  for (const ComponentId id : removed) {
    for (const openvdb::Coord& c : components_.at(id).voxels) {
      owner_.erase(c);
      if (scan.empty() || !scan.isInside(c)) pending.push_back(c);
    }
  }
  const std::vector<openvdb::Coord> found = scanFrontiers(map, scan);
  update.voxels_scanned = scan.empty() ? 0 : std::size_t(scan.volume());
  pending.insert(pending.end(), found.begin(), found.end());

  const ComponentId first = next_component_;
  floodComponents(std::move(pending));
  for (auto it = components_.lower_bound(first); it != components_.end(); ++it) {
    ++update.components_reflooded;
    it->second.clusters = makeClusters(map, it->second.voxels, &reusable, &update.added);
  }
  for (const ComponentId id : removed) components_.erase(id);
  // Clusters of taken-apart components that no new piece matched are gone.
  for (const auto& [voxel, ids] : reusable)
    for (const ClusterId cid : ids)
      if (cid != 0) update.removed.push_back(cid);
  std::sort(update.removed.begin(), update.removed.end());
  clusters_.erase(std::remove_if(clusters_.begin(), clusters_.end(),
                                 [&](const FrontierCluster& c) {
                                   return std::binary_search(update.removed.begin(), update.removed.end(), c.id);
                                 }),
                  clusters_.end());
  update.frontier_voxels = owner_.size();
  return update;
}

}  // namespace vdbmap::planner
