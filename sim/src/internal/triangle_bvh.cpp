#include "internal/triangle_bvh.hpp"

#include "vdbmap/triangle_geometry.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace vdbmap::sim::internal {
namespace {
constexpr int kBins = 16;
constexpr int kStackSize = 96;
constexpr int kMaxSahDepth = 48;  // beyond it, median splits: depth <= 48 + log2(n) < kStackSize

struct Box {
  std::array<float, 3> lo{std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
                          std::numeric_limits<float>::max()};
  std::array<float, 3> hi{-std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(),
                          -std::numeric_limits<float>::max()};
  void grow(const Box& b) {
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], b.lo[a]), hi[a] = std::max(hi[a], b.hi[a]);
  }
  void grow(const float* p) {
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  }
  float area() const {
    const float dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
    return dx < 0 ? 0.0f : 2.0f * (dx * dy + dy * dz + dz * dx);
  }
};

/// Moller-Trumbore in double on float corners: the ray parameter of the hit, or +inf.
double intersect(const float* a, const float* e1, const float* e2, const Vec3d& o, const Vec3d& d) {
  const Vec3d A(a[0], a[1], a[2]), E1(e1[0], e1[1], e1[2]), E2(e2[0], e2[1], e2[2]);
  const Vec3d p = d.cross(E2);
  const double det = E1.dot(p);
  if (det == 0.0) return std::numeric_limits<double>::infinity();
  const double inv = 1.0 / det;
  const Vec3d s = o - A;
  const double u = s.dot(p) * inv;
  if (u < -1e-9 || u > 1.0 + 1e-9) return std::numeric_limits<double>::infinity();
  const Vec3d q = s.cross(E1);
  const double v = d.dot(q) * inv;
  if (v < -1e-9 || u + v > 1.0 + 1e-9) return std::numeric_limits<double>::infinity();
  return E2.dot(q) * inv;
}
}  // namespace

TriangleBvh::TriangleBvh(const std::vector<Vec3d>& corners) {
  if (corners.empty() || corners.size() % 3 != 0)
    throw std::invalid_argument("TriangleBvh: need 3 corners per triangle");
  const std::size_t n = corners.size() / 3;
  if (n >= std::size_t(std::numeric_limits<std::int32_t>::max()))
    throw std::invalid_argument("TriangleBvh: too many triangles");
  tris_.resize(n);
  std::vector<float> centroids(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3d &a = corners[3 * i], &b = corners[3 * i + 1], &c = corners[3 * i + 2];
    for (int k = 0; k < 3; ++k) {
      tris_[i].a[k] = float(a[k]);
      tris_[i].e1[k] = float(b[k] - a[k]);
      tris_[i].e2[k] = float(c[k] - a[k]);
      centroids[3 * i + k] = float((a[k] + b[k] + c[k]) / 3.0);
    }
  }
  tri_index_.resize(n);
  std::iota(tri_index_.begin(), tri_index_.end(), 0);
  nodes_.reserve(2 * n / kMaxLeafTriangles + 1);
  build(0, std::uint32_t(n), centroids, 1);
  // A traversal stack holds at most one entry per level.
  if (depth_ >= kStackSize)
    throw std::runtime_error("TriangleBvh: tree depth " + std::to_string(depth_) + " exceeds the traversal stack");
  // Put the triangles in leaf order so a leaf reads contiguous memory.
  std::vector<Tri> ordered(n);
  for (std::size_t i = 0; i < n; ++i) ordered[i] = tris_[std::size_t(tri_index_[i])];
  tris_ = std::move(ordered);
}

std::uint32_t TriangleBvh::build(std::uint32_t begin, std::uint32_t end, std::vector<float>& centroids, int depth) {
  depth_ = std::max(depth_, depth);
  const std::uint32_t index = std::uint32_t(nodes_.size());
  nodes_.push_back({});
  auto triBox = [&](std::uint32_t k) {
    const Tri& t = tris_[std::size_t(tri_index_[k])];
    Box b;
    float p[3];
    b.grow(t.a);
    for (int a = 0; a < 3; ++a) p[a] = t.a[a] + t.e1[a];
    b.grow(p);
    for (int a = 0; a < 3; ++a) p[a] = t.a[a] + t.e2[a];
    b.grow(p);
    return b;
  };
  Box box, cbox;
  for (std::uint32_t k = begin; k < end; ++k) {
    box.grow(triBox(k));
    cbox.grow(&centroids[3 * std::size_t(tri_index_[k])]);
  }
  auto makeLeaf = [&]() {
    Node& node = nodes_[index];
    std::copy(box.lo.begin(), box.lo.end(), node.lo);
    std::copy(box.hi.begin(), box.hi.end(), node.hi);
    node.first = begin;
    node.count = end - begin;
    return index;
  };
  const std::uint32_t count = end - begin;
  if (count <= std::uint32_t(kMaxLeafTriangles)) return makeLeaf();

  // Binned SAH over the centroid box: the split (axis, bin) with the least A_l N_l + A_r N_r.
  int best_axis = -1, best_bin = 0;
  float best_cost = std::numeric_limits<float>::max();
  for (int axis = 0; axis < 3; ++axis) {
    const float extent = cbox.hi[axis] - cbox.lo[axis];
    if (!(extent > 0.0f)) continue;
    std::array<Box, kBins> bins;
    std::array<std::uint32_t, kBins> counts{};
    const float scale = float(kBins) / extent;
    for (std::uint32_t k = begin; k < end; ++k) {
      const float c = centroids[3 * std::size_t(tri_index_[k]) + std::size_t(axis)];
      const int b = std::min(kBins - 1, int((c - cbox.lo[axis]) * scale));
      bins[std::size_t(b)].grow(triBox(k));
      ++counts[std::size_t(b)];
    }
    std::array<float, kBins> right_area{};
    std::array<std::uint32_t, kBins> right_count{};
    Box acc;
    std::uint32_t n_acc = 0;
    for (int b = kBins - 1; b > 0; --b) {
      acc.grow(bins[std::size_t(b)]);
      n_acc += counts[std::size_t(b)];
      right_area[std::size_t(b)] = acc.area();
      right_count[std::size_t(b)] = n_acc;
    }
    acc = Box();
    n_acc = 0;
    for (int b = 0; b < kBins - 1; ++b) {
      acc.grow(bins[std::size_t(b)]);
      n_acc += counts[std::size_t(b)];
      if (n_acc == 0 || right_count[std::size_t(b + 1)] == 0) continue;
      const float cost =
          acc.area() * float(n_acc) + right_area[std::size_t(b + 1)] * float(right_count[std::size_t(b + 1)]);
      if (cost < best_cost) best_cost = cost, best_axis = axis, best_bin = b;
    }
  }
  std::uint32_t mid = begin + count / 2;
  if (depth >= kMaxSahDepth) best_axis = -1;  // bound the depth: median splits from here on
  if (best_axis >= 0) {
    const float scale = float(kBins) / (cbox.hi[best_axis] - cbox.lo[best_axis]);
    const auto it = std::partition(tri_index_.begin() + begin, tri_index_.begin() + end, [&](int t) {
      const float c = centroids[3 * std::size_t(t) + std::size_t(best_axis)];
      return std::min(kBins - 1, int((c - cbox.lo[best_axis]) * scale)) <= best_bin;
    });
    mid = std::uint32_t(it - tri_index_.begin());
  }
  if (best_axis < 0 || mid == begin || mid == end) {
    // Median split along the widest centroid extent (or by count when all centroids coincide).
    int axis = 0;
    for (int a = 1; a < 3; ++a)
      if (cbox.hi[a] - cbox.lo[a] > cbox.hi[axis] - cbox.lo[axis]) axis = a;
    mid = begin + count / 2;
    std::nth_element(tri_index_.begin() + begin, tri_index_.begin() + mid, tri_index_.begin() + end, [&](int x, int y) {
      return centroids[3 * std::size_t(x) + std::size_t(axis)] < centroids[3 * std::size_t(y) + std::size_t(axis)];
    });
  }

  build(begin, mid, centroids, depth + 1);
  const std::uint32_t right = build(mid, end, centroids, depth + 1);
  Node& node = nodes_[index];
  std::copy(box.lo.begin(), box.lo.end(), node.lo);
  std::copy(box.hi.begin(), box.hi.end(), node.hi);
  node.first = right;
  node.count = 0;
  return index;
}

TriangleBvh::Hit TriangleBvh::raycast(const Vec3d& origin, const Vec3d& dir, double t_max) const {
  Hit hit;
  float o[3], inv[3];
  for (int a = 0; a < 3; ++a) {
    o[a] = float(origin[a]);
    const float d = float(dir[a]);
    inv[a] = 1.0f / (std::abs(d) > 1e-30f ? d : std::copysign(1e-30f, d));
  }
  double best = t_max;
  // Entry parameter of a node's box along the ray, or +inf when missed or beyond `best`.
  auto enter = [&](const Node& n) {
    float t0 = 0.0f, t1 = float(best) * (1.0f + 1e-6f) + 1e-6f;
    for (int a = 0; a < 3; ++a) {
      float ta = (n.lo[a] - o[a]) * inv[a], tb = (n.hi[a] - o[a]) * inv[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
    }
    return t0 <= t1 ? t0 : std::numeric_limits<float>::infinity();
  };
  std::uint32_t stack[kStackSize];
  float stack_t[kStackSize];
  int sp = 0;
  std::uint32_t node = 0;
  if (!std::isfinite(enter(nodes_[0]))) return hit;
  for (;;) {
    const Node& n = nodes_[node];
    if (n.count > 0) {
      for (std::uint32_t k = n.first; k < n.first + n.count; ++k) {
        const Tri& t = tris_[k];
        const double th = intersect(t.a, t.e1, t.e2, origin, dir);
        if (th > 1e-9 && th <= best) {
          best = th;
          hit.t = th;
          hit.triangle = tri_index_[k];
        }
      }
    } else {
      const std::uint32_t left = node + 1, right = n.first;
      const float tl = enter(nodes_[left]), tr = enter(nodes_[right]);
      const bool hl = std::isfinite(tl), hr = std::isfinite(tr);
      if (hl && hr) {
        const bool left_first = tl <= tr;
        node = left_first ? left : right;
        stack[sp] = left_first ? right : left, stack_t[sp++] = left_first ? tr : tl;
        continue;
      }
      if (hl || hr) {
        node = hl ? left : right;
        continue;
      }
    }
    // Pop the next subtree that can still hold a nearer hit.
    for (;;) {
      if (sp == 0) return hit;
      --sp;
      if (double(stack_t[sp]) <= best) break;
    }
    node = stack[sp];
  }
}

double TriangleBvh::distance2(const Vec3d& p, double max_distance2) const {
  double best = max_distance2;
  auto boxDistance2 = [&](const Node& n) {
    double d2 = 0.0;
    for (int a = 0; a < 3; ++a) {
      const double g = std::max({double(n.lo[a]) - p[a], p[a] - double(n.hi[a]), 0.0});
      d2 += g * g;
    }
    return d2;
  };
  std::uint32_t stack[kStackSize];
  double stack_d[kStackSize];
  int sp = 0;
  std::uint32_t node = 0;
  if (boxDistance2(nodes_[0]) >= best) return best;
  for (;;) {
    const Node& n = nodes_[node];
    if (n.count > 0) {
      for (std::uint32_t k = n.first; k < n.first + n.count; ++k) {
        const Tri& t = tris_[k];
        const Vec3d a(t.a[0], t.a[1], t.a[2]);
        const Vec3d b = a + Vec3d(t.e1[0], t.e1[1], t.e1[2]), c = a + Vec3d(t.e2[0], t.e2[1], t.e2[2]);
        best = std::min(best, (p - closestPointOnTriangle(p, a, b, c)).squaredNorm());
      }
    } else {
      const std::uint32_t left = node + 1, right = n.first;
      const double dl = boxDistance2(nodes_[left]), dr = boxDistance2(nodes_[right]);
      const bool hl = dl < best, hr = dr < best;
      if (hl && hr) {
        const bool left_first = dl <= dr;
        node = left_first ? left : right;
        stack[sp] = left_first ? right : left, stack_d[sp++] = left_first ? dr : dl;
        continue;
      }
      if (hl || hr) {
        node = hl ? left : right;
        continue;
      }
    }
    for (;;) {
      if (sp == 0) return best;
      --sp;
      if (stack_d[sp] < best) break;
    }
    node = stack[sp];
  }
}

}  // namespace vdbmap::sim::internal
