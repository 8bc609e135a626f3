#include "vdbmap/planner/grid_search.hpp"
#include "vdbmap/field_check.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <queue>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

namespace vdbmap::planner {

namespace {

openvdb::Coord scaled(const openvdb::Coord& c, int k) { return openvdb::Coord(c.x() * k, c.y() * k, c.z() * k); }

int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
openvdb::Coord floorDiv(const openvdb::Coord& c, int b) {
  return openvdb::Coord(floorDiv(c.x(), b), floorDiv(c.y(), b), floorDiv(c.z(), b));
}
int ceilDiv(int a, int b) { return -floorDiv(-a, b); }

/// 21 bits per axis, offset so that negative indices pack too; orders the queue's ties.
std::uint64_t pack(const openvdb::Coord& c) {
  constexpr std::int64_t kOffset = std::int64_t{1} << 20;
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
  return ((std::uint64_t(c.x() + kOffset) & kMask) << 42) | ((std::uint64_t(c.y() + kOffset) & kMask) << 21) |
         (std::uint64_t(c.z() + kOffset) & kMask);
}
openvdb::Coord unpack(std::uint64_t key) {
  constexpr std::int64_t kOffset = std::int64_t{1} << 20;
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
  return openvdb::Coord(int(std::int64_t((key >> 42) & kMask) - kOffset),
                        int(std::int64_t((key >> 21) & kMask) - kOffset), int(std::int64_t(key & kMask) - kOffset));
}

/// The 26 steps, and their lengths in lattice cells.
struct Steps {
  std::array<openvdb::Coord, 26> step;
  std::array<double, 26> length;
  Steps() {
    int i = 0;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          if (dx == 0 && dy == 0 && dz == 0) continue;
          step[i] = openvdb::Coord(dx, dy, dz);
          length[i] = std::sqrt(double(dx * dx + dy * dy + dz * dz));
          ++i;
        }
  }
};
const Steps kSteps;

constexpr std::uint8_t kUnseen = 0xFF;
constexpr std::uint8_t kClosed = 0x80;
constexpr std::uint8_t kFromStart = 31;  ///< parent field of nodes joined to the start
constexpr std::size_t kMaxTable = std::size_t{1} << 24;

std::size_t tableIndex(const openvdb::Coord& ijk, const openvdb::Coord& origin, const openvdb::Coord& dim) {
  const openvdb::Coord d = ijk - origin;
  if (d.x() < 0 || d.y() < 0 || d.z() < 0 || d.x() >= dim.x() || d.y() >= dim.y() || d.z() >= dim.z())
    return std::size_t(-1);
  return (std::size_t(d.x()) * std::size_t(dim.y()) + std::size_t(d.y())) * std::size_t(dim.z()) + std::size_t(d.z());
}

}  // namespace

/// Voxel (x, y, z) of the block (0..7 each): word x, bit 8 y + z.
struct GridSearch::ClearBlock {
  std::array<std::uint64_t, 8> bits{};
};

/// The records of 8^3 nodes for both searches (from the start: side 0, from the goal: side 1).
struct GridSearch::NodeBlock {
  std::uint32_t generation = 0;
  std::array<std::array<double, 512>, 2> g;
  std::array<std::array<std::uint8_t, 512>, 2> state;  ///< kUnseen, or the parent's step (| kClosed)
};

void GridSearchConfig::validate() const {
  const FieldCheck check("GridSearchConfig");
  if (stride_vox < 1 || stride_vox > 8) check.fail("stride_vox", "[1, 8]", stride_vox);
  if (max_expansions < 1 || max_expansions > 100'000'000u) check.fail("max_expansions", "[1, 1e8]");
  check.inRange("heuristic_weight", heuristic_weight, 1.0, 1e4);
}

GridSearch::GridSearch(MapProbe& probe, double clearance_m, const Eigen::AlignedBox3d& bounds_W,
                       const GridSearchConfig& config)
    : probe_(&probe), reader_(probe.map().reader()), clearance_m_(clearance_m), config_(config) {
  config_.validate();
  const double half_diagonal_m = 0.5 * std::sqrt(3.0) * probe.voxelSize();
  node_radius_m_ = std::sqrt(clearance_m * clearance_m + half_diagonal_m * half_diagonal_m);
  voxels_ = probe.map().voxelsIn(bounds_W);
  if (voxels_.empty()) return;
  clear_origin_ = floorDiv(voxels_.min(), 8);
  clear_dim_ = floorDiv(voxels_.max(), 8) - clear_origin_ + openvdb::Coord(1);
  const int s = config_.stride_vox;
  const openvdb::Coord node_lo(ceilDiv(voxels_.min().x(), s), ceilDiv(voxels_.min().y(), s),
                               ceilDiv(voxels_.min().z(), s));
  const openvdb::Coord node_hi(floorDiv(voxels_.max().x(), s), floorDiv(voxels_.max().y(), s),
                               floorDiv(voxels_.max().z(), s));
  node_origin_ = floorDiv(node_lo, 8);
  node_dim_ = floorDiv(node_hi, 8) - node_origin_ + openvdb::Coord(1);
  const auto count = [](const openvdb::Coord& d) {
    return std::size_t(d.x()) * std::size_t(d.y()) * std::size_t(d.z());
  };
  if (count(clear_dim_) > kMaxTable)
    throw std::invalid_argument("GridSearch: the bounds span " + std::to_string(count(clear_dim_)) +
                                " blocks of 8^3 voxels; at most 2^24 are supported");
  clear_index_.assign(count(clear_dim_), -1);
  node_index_.assign(
      node_lo.x() <= node_hi.x() && node_lo.y() <= node_hi.y() && node_lo.z() <= node_hi.z() ? count(node_dim_) : 0,
      -1);
}

GridSearch::~GridSearch() = default;

Vec3d GridSearch::nodeCentre(const openvdb::Coord& node) const {
  return voxelCenterOf(scaled(node, config_.stride_vox), probe_->voxelSize());
}

void GridSearch::fillClearBlock(const openvdb::Coord& block_ijk, ClearBlock& out) {
  const double r_vox = node_radius_m_ / probe_->voxelSize();
  const int pad = int(std::ceil(r_vox));
  const openvdb::Coord first = scaled(block_ijk, 8);
  auto inside = [&](int x, int y, int z) { return voxels_.isInside(first.offsetBy(x, y, z)); };
  if (8 + 2 * pad > 64) {
    // Too wide for one 64-bit row per column: voxel by voxel.
    for (int x = 0; x < 8; ++x)
      for (int y = 0; y < 8; ++y)
        for (int z = 0; z < 8; ++z)
          if (inside(x, y, z) &&
              probe_->isClear(voxelCenterOf(first.offsetBy(x, y, z), probe_->voxelSize()), node_radius_m_))
            out.bits[x] |= std::uint64_t{1} << (8 * y + z);
    return;
  }
  // A voxel centre is clear when no voxel within r_vox of it is other than free: the padded box's
  // non-free voxels as one bit row along z per (x, y), dilated along z by each half-height the
  // sphere has, then or-ed over the sphere's (dx, dy) columns.
  const int side = 8 + 2 * pad;
  const openvdb::CoordBBox box(first.offsetBy(-pad, -pad, -pad), first.offsetBy(7 + pad, 7 + pad, 7 + pad));
  std::vector<Occupancy> states(std::size_t(side) * side * side);
  reader_->readBox(box, states.data());
  std::vector<std::uint64_t> dilated(std::size_t(pad + 1) * side * side);  // [h][x][y]
  for (int x = 0; x < side; ++x)
    for (int y = 0; y < side; ++y) {
      std::uint64_t row = 0;
      const Occupancy* column = &states[(std::size_t(x) * side + y) * side];
      for (int z = 0; z < side; ++z)
        if (column[z] != Occupancy::Free) row |= std::uint64_t{1} << z;
      std::uint64_t acc = row;
      dilated[std::size_t(x) * side + y] = acc;
      for (int h = 1; h <= pad; ++h) {
        acc |= (row << h) | (row >> h);
        dilated[(std::size_t(h) * side + x) * side + y] = acc;
      }
    }
  const double r2 = r_vox * r_vox;
  for (int x = 0; x < 8; ++x)
    for (int y = 0; y < 8; ++y) {
      std::uint64_t blocked = 0;
      for (int dx = -pad; dx <= pad; ++dx)
        for (int dy = -pad; dy <= pad; ++dy) {
          const double rest = r2 - double(dx * dx + dy * dy);
          if (rest < 0.0) continue;
          const int h = std::min(pad, int(std::floor(std::sqrt(rest))));
          blocked |= dilated[(std::size_t(h) * side + (x + pad + dx)) * side + (y + pad + dy)];
        }
      std::uint64_t clear = ~(blocked >> pad) & 0xFFu;
      for (int z = 0; z < 8; ++z)
        if (!inside(x, y, z)) clear &= ~(std::uint64_t{1} << z);
      out.bits[x] |= clear << (8 * y);
    }
}

bool GridSearch::centreClear(const openvdb::Coord& voxel) {
  if (!voxels_.isInside(voxel)) return false;
  const openvdb::Coord block = floorDiv(voxel, 8);
  std::int32_t& index = clear_index_[tableIndex(block, clear_origin_, clear_dim_)];
  if (index < 0) {
    index = std::int32_t(clear_blocks_.size());
    clear_blocks_.emplace_back();
    fillClearBlock(block, clear_blocks_.back());
    ++blocks_computed_;
  }
  const openvdb::Coord local = voxel - scaled(block, 8);
  return (clear_blocks_[std::size_t(index)].bits[std::size_t(local.x())] >> (8 * local.y() + local.z())) & 1u;
}

bool GridSearch::edgeClear(const openvdb::Coord& from_node, const openvdb::Coord& step) {
  const openvdb::Coord first = scaled(from_node, config_.stride_vox);
  for (int t = 1; t <= config_.stride_vox; ++t)
    if (!centreClear(first + scaled(step, t))) return false;
  return true;
}

GridSearch::NodeRef GridSearch::node(const openvdb::Coord& n) {
  const openvdb::Coord block = floorDiv(n, 8);
  const std::size_t at = tableIndex(block, node_origin_, node_dim_);
  if (at == std::size_t(-1) || at >= node_index_.size()) return {nullptr, 0};
  std::int32_t& index = node_index_[at];
  if (index < 0) {
    index = std::int32_t(node_blocks_.size());
    node_blocks_.push_back(std::make_unique<NodeBlock>());
  }
  NodeBlock* b = node_blocks_[std::size_t(index)].get();
  if (b->generation != generation_) {
    b->generation = generation_;
    b->state[0].fill(kUnseen);
    b->state[1].fill(kUnseen);
  }
  const openvdb::Coord local = n - scaled(block, 8);
  return {b, (local.x() * 8 + local.y()) * 8 + local.z()};
}

std::vector<openvdb::Coord> GridSearch::attachNodes(const Vec3d& p_W, std::size_t max_nodes) {
  const double cell_m = config_.stride_vox * probe_->voxelSize();
  const Vec3d q = p_W / cell_m;
  const openvdb::Coord low(int(std::floor(q.x())), int(std::floor(q.y())), int(std::floor(q.z())));
  // The 4 x 4 x 4 nodes around p's lattice cell: its corners and one ring beyond.
  std::vector<std::pair<double, openvdb::Coord>> candidates;
  for (int dx = -1; dx <= 2; ++dx)
    for (int dy = -1; dy <= 2; ++dy)
      for (int dz = -1; dz <= 2; ++dz) {
        const openvdb::Coord node = low.offsetBy(dx, dy, dz);
        candidates.emplace_back((nodeCentre(node) - p_W).squaredNorm(), node);
      }
  std::sort(candidates.begin(), candidates.end(), [](const auto& a, const auto& b) {
    return std::make_tuple(a.first, a.second.x(), a.second.y(), a.second.z()) <
           std::make_tuple(b.first, b.second.x(), b.second.y(), b.second.z());
  });
  std::vector<openvdb::Coord> nodes;
  for (const auto& [d2, node] : candidates) {
    if (nodes.size() >= max_nodes) break;
    if (centreClear(scaled(node, config_.stride_vox)) && probe_->isSegmentClear(p_W, nodeCentre(node), clearance_m_))
      nodes.push_back(node);
  }
  return nodes;
}

std::vector<Vec3d> GridSearch::shorten(std::vector<Vec3d> points) {
  // Merge collinear steps: their union is the segment between the ends, already clear.
  std::vector<Vec3d> corners{points.front()};
  for (std::size_t i = 1; i + 1 < points.size(); ++i) {
    const Vec3d in = (points[i] - corners.back()).normalized(), out = (points[i + 1] - points[i]).normalized();
    if (in.dot(out) < 1.0 - 1e-9) corners.push_back(points[i]);
  }
  corners.push_back(points.back());
  // Greedy: from each kept point, jump as far as a clear segment reaches (doubling, then bisecting).
  std::vector<Vec3d> out{corners.front()};
  std::size_t i = 0;
  const std::size_t last = corners.size() - 1;
  auto sees = [&](std::size_t a, std::size_t b) {
    return b == a + 1 || probe_->isSegmentClear(corners[a], corners[b], clearance_m_);
  };
  while (i < last) {
    std::size_t good = i + 1, step = 2;
    std::size_t bad = last + 1;
    while (good < last) {
      const std::size_t j = std::min(last, i + step);
      if (sees(i, j)) {
        good = j;
        step *= 2;
      } else {
        bad = j;
        break;
      }
    }
    while (bad - good > 1) {
      const std::size_t mid = (good + bad) / 2;
      (sees(i, mid) ? good : bad) = mid;
    }
    out.push_back(corners[good]);
    i = good;
  }
  return out;
}

GridSearchResult GridSearch::search(const Vec3d& start_W, const Vec3d& goal_W, const std::function<bool()>& stop) {
  GridSearchResult result;
  const std::uint64_t blocks_before = blocks_computed_;
  auto finish = [&](GridSearchResult r) {
    r.clear_blocks = blocks_computed_ - blocks_before;
    return r;
  };
  if (node_index_.empty()) return finish(result);
  ++generation_;  // every node record is fresh for this search

  // Two searches, one from each end, take turns. Either one reaching its target gives the path;
  // either one running out of nodes proves that there is none on the lattice (the start's or the
  // goal's pocket is closed), which is often quick from the side of a small pocket.
  using Entry = std::pair<double, std::uint64_t>;  // f, node: ties by node, the same on every run
  struct Side {
    Vec3d from_W, to_W;
    std::vector<std::uint64_t> targets;  // nodes joined to to_W; few: a linear scan
    std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  };
  constexpr std::size_t kAttach = 8;
  std::array<Side, 2> sides;
  sides[0].from_W = sides[1].to_W = start_W;
  sides[0].to_W = sides[1].from_W = goal_W;
  std::array<std::vector<openvdb::Coord>, 2> attached;
  for (int k = 0; k < 2; ++k) {
    attached[k] = attachNodes(sides[k].from_W, kAttach);
    if (attached[k].empty()) return finish(result);
  }
  for (int k = 0; k < 2; ++k)
    for (const openvdb::Coord& n : attached[1 - k]) sides[k].targets.push_back(pack(n));

  const double w = config_.heuristic_weight;
  auto push = [&](int k, const openvdb::Coord& n, double g, std::uint8_t parent) {
    const NodeRef ref = node(n);
    if (!ref.block) return;
    std::uint8_t& state = ref.block->state[k][std::size_t(ref.index)];
    double& g_old = ref.block->g[k][std::size_t(ref.index)];
    if (state != kUnseen && ((state & kClosed) || g_old <= g)) return;
    g_old = g;
    state = parent;
    sides[k].open.emplace(g + w * (nodeCentre(n) - sides[k].to_W).norm(), pack(n));
  };
  for (int k = 0; k < 2; ++k)
    for (const openvdb::Coord& n : attached[k]) push(k, n, (nodeCentre(n) - sides[k].from_W).norm(), kFromStart);

  const double cell_m = config_.stride_vox * probe_->voxelSize();
  int winner = -1;
  std::uint64_t reached = 0;
  for (int k = 0; winner < 0; k = 1 - k) {
    Side& side = sides[std::size_t(k)];
    if (side.open.empty()) return finish(result);  // this end's pocket holds no path
    if (result.expansions >= config_.max_expansions || (stop && stop())) return finish(result);
    // Pop this side's next open node (skipping entries its improvement made stale).
    std::uint64_t key = 0;
    NodeRef ref{nullptr, 0};
    while (!side.open.empty()) {
      key = side.open.top().second;
      side.open.pop();
      ref = node(unpack(key));
      if (!(ref.block->state[k][std::size_t(ref.index)] & kClosed)) break;
      ref.block = nullptr;
    }
    if (!ref.block) continue;  // emptied: the check above ends the search on this side's next turn
    ref.block->state[k][std::size_t(ref.index)] |= kClosed;
    if (std::find(side.targets.begin(), side.targets.end(), key) != side.targets.end()) {
      // With weight 1, f = g + this node's own segment to the end: the cheapest completion on
      // this side, since entries leave the queue in order of f and the heuristic is admissible.
      winner = k;
      reached = key;
      break;
    }
    ++result.expansions;
    const openvdb::Coord n = unpack(key);
    const double g = ref.block->g[k][std::size_t(ref.index)];
    for (std::uint8_t d = 0; d < 26; ++d) {
      const openvdb::Coord next = n + kSteps.step[d];
      const NodeRef to = node(next);
      if (!to.block) continue;
      const std::uint8_t state = to.block->state[k][std::size_t(to.index)];
      if (state != kUnseen && (state & kClosed)) continue;
      if (!edgeClear(n, kSteps.step[d])) continue;
      push(k, next, g + cell_m * kSteps.length[d], d);
    }
  }

  // The winner's chain runs from its target node back to its own end.
  std::vector<Vec3d> points{sides[std::size_t(winner)].to_W};
  for (openvdb::Coord n = unpack(reached);;) {
    points.push_back(nodeCentre(n));
    const NodeRef ref = node(n);
    const std::uint8_t parent = ref.block->state[winner][std::size_t(ref.index)] & std::uint8_t(~kClosed);
    if (parent == kFromStart) break;
    n = n - kSteps.step[parent];
  }
  points.push_back(sides[std::size_t(winner)].from_W);
  if (winner == 0) std::reverse(points.begin(), points.end());  // start ... goal
  // The start or goal may sit on a node.
  points.erase(std::unique(points.begin(), points.end(),
                           [](const Vec3d& p, const Vec3d& q) { return (p - q).squaredNorm() < 1e-18; }),
               points.end());
  if (points.size() < 2) points.push_back(goal_W);
  result.waypoints = shorten(std::move(points));
  result.found = true;
  return finish(result);
}

}  // namespace vdbmap::planner
