#include "vdbmap/planner/frontier.hpp"
#include "vdbmap/field_check.hpp"

#include <Eigen/Eigenvalues>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>
#include <string>

namespace vdbmap::planner {

namespace {

/// The 26 neighbours of a voxel (faces, edges, corners).
std::vector<openvdb::Coord> allNeighbours() {
  std::vector<openvdb::Coord> n;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z)
        if (x || y || z) n.emplace_back(x, y, z);
  return n;
}
/// The 13 of the 26 neighbours that come before a voxel in Coord order (x, then y, then z).
std::vector<openvdb::Coord> earlierNeighbours() {
  std::vector<openvdb::Coord> n;
  for (const openvdb::Coord& d : allNeighbours())
    if (d < openvdb::Coord(0)) n.push_back(d);
  return n;
}
const std::vector<openvdb::Coord> kEarlierNeighbours = earlierNeighbours();

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

/// One sorted vector from sorted runs, merged pairwise (n log k for n voxels in k runs).
std::vector<openvdb::Coord> mergeSortedRuns(std::vector<std::vector<openvdb::Coord>> runs) {
  if (runs.empty()) return {};
  while (runs.size() > 1) {
    std::vector<std::vector<openvdb::Coord>> merged;
    for (std::size_t i = 0; i + 1 < runs.size(); i += 2) {
      std::vector<openvdb::Coord>& both = merged.emplace_back();
      both.reserve(runs[i].size() + runs[i + 1].size());
      std::merge(runs[i].begin(), runs[i].end(), runs[i + 1].begin(), runs[i + 1].end(), std::back_inserter(both));
    }
    if (runs.size() % 2 == 1) merged.push_back(std::move(runs.back()));
    runs = std::move(merged);
  }
  return std::move(runs.front());
}

}  // namespace

void FrontierConfig::validate() const {
  const FieldCheck check("FrontierConfig");
  if (min_cluster_size < 1 || min_cluster_size > 100000000) check.fail("min_cluster_size", "[1, 1e8]");
  if (!(split_radius_xy_m > 0.0 && split_radius_xy_m <= 1e4)) check.fail("split_radius_xy_m", "(0, 1e4]");
  if (sample_stride_vox < 1 || sample_stride_vox > 64) check.fail("sample_stride_vox", "[1, 64]");
  if (bounds_W && (bounds_W->isEmpty() || !bounds_W->min().allFinite() || !bounds_W->max().allFinite()))
    check.fail("bounds_W", "non-empty finite boxes");
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

std::size_t CoordHash::operator()(const openvdb::Coord& c) const noexcept {
  std::uint64_t h = std::uint64_t(std::uint32_t(c.x())) * 0x9E3779B97F4A7C15ULL;
  h ^= std::uint64_t(std::uint32_t(c.y())) * 0xC2B2AE3D27D4EB4FULL + (h << 6) + (h >> 2);
  h ^= std::uint64_t(std::uint32_t(c.z())) * 0x165667B19E3779F9ULL + (h << 6) + (h >> 2);
  return std::size_t(h ^ (h >> 31));
}

FrontierMap::FrontierMap(const FrontierConfig& params) : params_(params) { params_.validate(); }

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
  // Chunks of x-slabs, each read as one block (with a one-voxel margin for the neighbours) by its
  // own reader; chunks are concatenated in order, so the result does not depend on the threads.
  constexpr int kSlabsPerChunk = 8;
  const int slabs = box.dim().x();
  const int chunks = (slabs + kSlabsPerChunk - 1) / kSlabsPerChunk;
  std::vector<std::vector<openvdb::Coord>> found(static_cast<std::size_t>(chunks));
  tbb::parallel_for(tbb::blocked_range<int>(0, chunks, 1), [&](const tbb::blocked_range<int>& r) {
    std::unique_ptr<MapReader> reader = map.reader();
    std::vector<Occupancy> block;
    for (int chunk = r.begin(); chunk < r.end(); ++chunk) {
      const int x0 = box.min().x() + chunk * kSlabsPerChunk;
      const int x1 = std::min(box.max().x(), x0 + kSlabsPerChunk - 1);
      const openvdb::CoordBBox inner(openvdb::Coord(x0, box.min().y(), box.min().z()),
                                     openvdb::Coord(x1, box.max().y(), box.max().z()));
      const openvdb::CoordBBox outer = inner.expandBy(1);
      const openvdb::Coord dim = outer.dim();
      block.resize(std::size_t(outer.volume()));
      reader->readBox(outer, block.data());
      auto at = [&](int x, int y, int z) -> Occupancy& {
        return block[(std::size_t(x - outer.min().x()) * std::size_t(dim.y()) + std::size_t(y - outer.min().y())) *
                         std::size_t(dim.z()) +
                     std::size_t(z - outer.min().z())];
      };
      // Outside the exploration box nothing is a frontier, nor makes one.
      if (params_.bounds_W)
        for (auto it = outer.begin(); it; ++it)
          if (!bounds.isInside(*it)) at((*it).x(), (*it).y(), (*it).z()) = Occupancy::Occupied;
      std::vector<openvdb::Coord>& out = found[std::size_t(chunk)];
      for (int x = x0; x <= x1; ++x)
        for (int y = inner.min().y(); y <= inner.max().y(); ++y)
          for (int z = inner.min().z(); z <= inner.max().z(); ++z) {
            if (at(x, y, z) != Occupancy::Free) continue;
            if (at(x - 1, y, z) == Occupancy::Unknown || at(x + 1, y, z) == Occupancy::Unknown ||
                at(x, y - 1, z) == Occupancy::Unknown || at(x, y + 1, z) == Occupancy::Unknown ||
                at(x, y, z - 1) == Occupancy::Unknown || at(x, y, z + 1) == Occupancy::Unknown)
              out.emplace_back(x, y, z);
          }
    }
  });
  std::vector<openvdb::Coord> all;
  for (auto& f : found) all.insert(all.end(), f.begin(), f.end());
  return all;
}

void FrontierMap::floodComponents(std::vector<openvdb::Coord> pending) {
  // Union-find over the pending voxels: each voxel is joined with its 13 neighbours that come
  // before it in Coord order (the other 13 see it from their side). Components are numbered in
  // the order of their smallest voxel, and their voxels come out sorted: deterministic.
  if (!std::is_sorted(pending.begin(), pending.end())) std::sort(pending.begin(), pending.end());
  const std::size_t n = pending.size();
  std::vector<std::uint32_t> parent(n);
  for (std::size_t i = 0; i < n; ++i) parent[i] = std::uint32_t(i);
  auto root = [&parent](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  // Adding a fixed offset keeps Coord order, so each neighbour offset's voxel is found by a
  // cursor that only moves forward through the sorted voxels (a merge; no lookup table).
  std::vector<std::size_t> cursor(kEarlierNeighbours.size(), 0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t k = 0; k < kEarlierNeighbours.size(); ++k) {
      const openvdb::Coord target = pending[i] + kEarlierNeighbours[k];
      std::size_t& j = cursor[k];
      while (pending[j] < target) ++j;  // stops at i at the latest: target < pending[i]
      if (pending[j] != target) continue;
      const std::uint32_t a = root(std::uint32_t(i)), b = root(std::uint32_t(j));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);  // the root is the smallest index
    }
  struct Numbered {
    ComponentId id = 0;  // 0: not numbered yet (ids start at 1)
    Component* component = nullptr;
  };
  std::vector<Numbered> of_root(n);
  for (std::size_t i = 0; i < n; ++i) {
    Numbered& numbered = of_root[root(std::uint32_t(i))];
    if (numbered.id == 0) {
      numbered.id = next_component_++;
      numbered.component = &components_.emplace(numbered.id, Component{}).first->second;
    }
    numbered.component->voxels.push_back(pending[i]);
    numbered.component->bbox.expand(pending[i]);
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
    c.component_voxels = voxels.size();
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
  frontier_voxels_.clear();
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
  frontier_voxels_.insert(found.begin(), found.end());
  const std::size_t first = next_component_;
  floodComponents(std::move(found));
  for (auto it = components_.lower_bound(first); it != components_.end(); ++it) {
    it->second.clusters = makeClusters(map, it->second.voxels, nullptr, &update.added);
  }
  update.components_reflooded = components_.size();
  update.frontier_voxels = frontier_voxels_.size();
  return update;
}

void FrontierMap::dropClusters(const std::vector<ClusterId>& sorted_ids) {
  clusters_.erase(std::remove_if(clusters_.begin(), clusters_.end(),
                                 [&](const FrontierCluster& c) {
                                   return std::binary_search(sorted_ids.begin(), sorted_ids.end(), c.id);
                                 }),
                  clusters_.end());
}

FrontierUpdate FrontierMap::setMinClusterSize(const MapQuery& map, int min_cluster_size) {
  FrontierConfig changed = params_;
  changed.min_cluster_size = min_cluster_size;
  changed.validate();
  checkVoxelSize(map);
  params_ = changed;
  FrontierUpdate update;
  for (auto& [id, comp] : components_) {
    const bool big_enough = int(comp.voxels.size()) >= params_.min_cluster_size;
    if (big_enough && comp.clusters.empty()) {
      comp.clusters = makeClusters(map, comp.voxels, nullptr, &update.added);
    } else if (!big_enough && !comp.clusters.empty()) {
      update.removed.insert(update.removed.end(), comp.clusters.begin(), comp.clusters.end());
      comp.clusters.clear();
    }
  }
  std::sort(update.added.begin(), update.added.end());
  std::sort(update.removed.begin(), update.removed.end());
  dropClusters(update.removed);
  update.frontier_voxels = frontier_voxels_.size();
  return update;
}

FrontierUpdate FrontierMap::update(const MapQuery& map, const openvdb::CoordBBox& dirty) {
  FrontierUpdate update;
  checkVoxelSize(map);
  if (dirty.empty()) {
    update.frontier_voxels = frontier_voxels_.size();
    return update;
  }
  // Voxels whose status may have changed, and the region whose components may have changed.
  openvdb::CoordBBox scan = dirty.expandBy(1);
  if (params_.bounds_W) scan.intersect(boundsIndex(map));
  const openvdb::CoordBBox reach = dirty.expandBy(2);

  // Components touching the reach are taken apart; their voxels outside the scan keep their
  // status and are flooded again together with the new frontier voxels of the scan.
  std::vector<ComponentId> removed;
  ReusableClusters reusable;  // the taken-apart clusters, by first voxel
  for (const auto& [id, comp] : components_) {
    if (!overlaps(comp.bbox, reach)) continue;
    if (std::none_of(comp.voxels.begin(), comp.voxels.end(), [&](const openvdb::Coord& c) { return reach.isInside(c); }))
      continue;
    removed.push_back(id);
    for (const ClusterId cid : comp.clusters) reusable[find(cid)->voxels.front()].push_back(cid);
  }
  // Voxels outside the scan stay frontier voxels; inside it, the scan says which are. Each
  // component's voxels and the scan's come sorted, and no voxel is in two of them: the flood gets
  // them merged, not sorted whole.
  std::vector<std::vector<openvdb::Coord>> runs;
  for (const ComponentId id : removed) {
    std::vector<openvdb::Coord>& kept = runs.emplace_back();
    for (const openvdb::Coord& c : components_.at(id).voxels) {
      if (scan.empty() || !scan.isInside(c))
        kept.push_back(c);
      else
        frontier_voxels_.erase(c);
    }
  }
  std::vector<openvdb::Coord>& found = runs.emplace_back(scanFrontiers(map, scan));
  update.voxels_scanned = scan.empty() ? 0 : std::size_t(scan.volume());
  frontier_voxels_.insert(found.begin(), found.end());

  const ComponentId first = next_component_;
  floodComponents(mergeSortedRuns(std::move(runs)));
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
  dropClusters(update.removed);
  update.frontier_voxels = frontier_voxels_.size();
  return update;
}

}  // namespace vdbmap::planner
