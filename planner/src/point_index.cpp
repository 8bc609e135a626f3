#include "vdbmap/planner/point_index.hpp"

// nanoflann 1.4.3's dynamic index copies a tree whose bounding box is not set yet (it is computed
// at the first build): GCC 12 flags the copy when it inlines the constructor.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <nanoflann.hpp>
#pragma GCC diagnostic pop

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace vdbmap::planner {
namespace {

struct PointsAdaptor {
  const std::vector<Vec3d>* points;
  std::size_t kdtree_get_point_count() const { return points->size(); }
  double kdtree_get_pt(std::size_t i, std::size_t d) const { return (*points)[i][int(d)]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const {
    return false;
  }
};

using DynamicTree =
    nanoflann::KDTreeSingleIndexDynamicAdaptor<nanoflann::L2_Simple_Adaptor<double, PointsAdaptor>, PointsAdaptor, 3>;

constexpr std::size_t kLeafSize = 16;

double squaredDistance(const Vec3d& a, const Vec3d& b) {
  const double dx = a.x() - b.x(), dy = a.y() - b.y(), dz = a.z() - b.z();
  return dx * dx + dy * dy + dz * dz;
}

/// Collects the points within the radius. The tree prunes against a slightly larger bound and
/// the exact test is done here, so a point exactly on the sphere is found whatever order the
/// tree sums its distances in.
class WithinRadius {
 public:
  using DistanceType = double;
  using IndexType = std::uint32_t;

  WithinRadius(const std::vector<Vec3d>& points, const Vec3d& centre, double radius_m)
      : points_(points),
        centre_(centre),
        radius_sq_(radius_m * radius_m),
        prune_sq_(radius_sq_ * (1.0 + 1e-9) + 1e-12) {}

  // The result-set interface nanoflann's searchLevel calls.
  bool full() const { return true; }
  double worstDist() const { return prune_sq_; }
  std::size_t size() const { return found_.size(); }
  bool addPoint(DistanceType /*tree_distance_sq*/, IndexType index) {
    if (squaredDistance(points_[index], centre_) <= radius_sq_) found_.push_back(index);
    return true;  // keep searching
  }

  std::vector<std::size_t> take() {
    std::sort(found_.begin(), found_.end());
    return std::move(found_);
  }

 private:
  const std::vector<Vec3d>& points_;
  Vec3d centre_;
  double radius_sq_, prune_sq_;
  std::vector<std::size_t> found_;
};

void requireFinite(const Vec3d& p, const char* what) {
  if (!p.allFinite()) throw std::invalid_argument(std::string("PointIndex: ") + what + " is not finite");
}

}  // namespace

struct PointIndex::Trees {
  std::vector<Vec3d> points;
  PointsAdaptor adaptor{&points};
  std::unique_ptr<DynamicTree> tree;

  void rebuild() {
    // The dynamic index adds every point the adaptor holds at construction.
    tree = std::make_unique<DynamicTree>(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
  }
};

PointIndex::PointIndex() : trees_(std::make_unique<Trees>()) { trees_->rebuild(); }
PointIndex::~PointIndex() = default;
PointIndex::PointIndex(PointIndex&&) noexcept = default;
PointIndex& PointIndex::operator=(PointIndex&&) noexcept = default;

std::size_t PointIndex::add(const Vec3d& p) {
  requireFinite(p, "a point");
  const std::size_t i = trees_->points.size();
  trees_->points.push_back(p);
  trees_->tree->addPoints(std::uint32_t(i), std::uint32_t(i));
  return i;
}

void PointIndex::reset(const std::vector<Vec3d>& points) {
  for (const Vec3d& p : points) requireFinite(p, "a point");
  trees_->points = points;
  trees_->rebuild();
}

std::size_t PointIndex::size() const { return trees_->points.size(); }

const Vec3d& PointIndex::operator[](std::size_t i) const { return trees_->points.at(i); }

std::vector<std::size_t> PointIndex::withinRadius(const Vec3d& centre, double radius_m) const {
  requireFinite(centre, "the query centre");
  if (!(radius_m >= 0.0 && std::isfinite(radius_m)))
    throw std::invalid_argument("PointIndex::withinRadius: radius_m must be finite and >= 0");
  WithinRadius result(trees_->points, centre, radius_m);
  if (!trees_->points.empty()) trees_->tree->findNeighbors(result, centre.data(), nanoflann::SearchParams());
  return result.take();
}

}  // namespace vdbmap::planner
