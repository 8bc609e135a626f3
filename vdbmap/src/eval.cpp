#include "vdbmap/eval.hpp"

#include "vdbmap/triangle_geometry.hpp"
#include "vdbmap/tsdf_volume.hpp"  // kMaxAbsPosition_m

#include <nanoflann.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>

namespace vdbmap {
namespace {

struct PointsAdaptor {
  const std::vector<Vec3d>* pts;
  std::size_t kdtree_get_point_count() const { return pts->size(); }
  double kdtree_get_pt(std::size_t i, std::size_t d) const { return (*pts)[i][int(d)]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const { return false; }
};
using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointsAdaptor>, PointsAdaptor, 3>;

constexpr std::size_t kCandidates = 8;
}  // namespace

struct SurfaceDistance::Index {
  std::vector<Vec3d> vertices;
  std::vector<Eigen::Vector3i> triangles;
  std::vector<Vec3d> samples;
  std::vector<int> sample_triangle;  // -1 for point clouds
  PointsAdaptor sample_adaptor{&samples}, vertex_adaptor{&vertices};
  std::unique_ptr<KdTree> sample_tree, vertex_tree;
};

namespace {
/// About 10 GB of samples and kd-tree: beyond it the spacing is too fine for the mesh.
constexpr double kMaxSurfaceSamples = 2e8;
}  // namespace

SurfaceDistance::SurfaceDistance(const TriangleMesh& mesh, double spacing) : index_(std::make_unique<Index>()) {
  if (mesh.vertices.empty()) throw std::invalid_argument("SurfaceDistance: the mesh has no vertices");
  if (!(spacing > 0)) throw std::invalid_argument("SurfaceDistance: sample spacing must be > 0");
  Index& ix = *index_;
  for (const Vec3f& v : mesh.vertices) {
    if (!v.allFinite() || v.cwiseAbs().maxCoeff() > kMaxAbsPosition_m) {
      std::ostringstream msg;
      msg << "SurfaceDistance: mesh vertex " << ix.vertices.size() << " (" << v.transpose()
          << ") is not finite or beyond " << kMaxAbsPosition_m << " m";
      throw std::invalid_argument(msg.str());
    }
    ix.vertices.push_back(v.cast<double>());
  }
  // The samples are bounded before any is drawn: a mesh's area decides them, not its vertex count.
  double total_area = 0.0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    if ((t.array() < 0).any() || (t.array() >= int(ix.vertices.size())).any()) continue;
    const Vec3d &a = ix.vertices[t[0]], &b = ix.vertices[t[1]], &c = ix.vertices[t[2]];
    total_area += 0.5 * (b - a).cross(c - a).norm();
  }
  if (total_area / (spacing * spacing) > kMaxSurfaceSamples) {
    std::ostringstream msg;
    msg << "SurfaceDistance: the mesh's " << total_area << " m^2 at a sample spacing of " << spacing << " m need "
        << total_area / (spacing * spacing) << " samples, more than " << kMaxSurfaceSamples
        << "; use a coarser spacing";
    throw std::invalid_argument(msg.str());
  }
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  for (const Eigen::Vector3i& t : mesh.triangles) {
    if ((t.array() < 0).any() || (t.array() >= int(ix.vertices.size())).any()) continue;
    const Vec3d &a = ix.vertices[t[0]], &b = ix.vertices[t[1]], &c = ix.vertices[t[2]];
    const double area = 0.5 * (b - a).cross(c - a).norm();
    const int tri = int(ix.triangles.size());
    ix.triangles.push_back(t);
    // The centroid always, then area-proportional uniform samples.
    ix.samples.push_back((a + b + c) / 3.0);
    ix.sample_triangle.push_back(tri);
    const double expected = area / (spacing * spacing);
    std::size_t n = std::size_t(expected);
    if (uni(rng) < expected - double(n)) ++n;
    for (std::size_t k = 0; k < n; ++k) {
      double r1 = uni(rng), r2 = uni(rng);
      if (r1 + r2 > 1) {
        r1 = 1 - r1;
        r2 = 1 - r2;
      }
      ix.samples.push_back(a + r1 * (b - a) + r2 * (c - a));
      ix.sample_triangle.push_back(tri);
    }
  }
  if (ix.triangles.empty()) {  // a point cloud: its points are the surface
    ix.samples = ix.vertices;
    ix.sample_triangle.assign(ix.samples.size(), -1);
  }
  ix.sample_tree = std::make_unique<KdTree>(3, ix.sample_adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  ix.sample_tree->buildIndex();
  ix.vertex_tree = std::make_unique<KdTree>(3, ix.vertex_adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  ix.vertex_tree->buildIndex();
}

SurfaceDistance::~SurfaceDistance() = default;
SurfaceDistance::SurfaceDistance(SurfaceDistance&&) noexcept = default;

const std::vector<Vec3d>& SurfaceDistance::samples() const { return index_->samples; }

double SurfaceDistance::distance(const Vec3d& p) const {
  const Index& ix = *index_;
  std::uint32_t idx[kCandidates];
  double d2[kCandidates];
  const std::size_t n = ix.sample_tree->knnSearch(p.data(), kCandidates, idx, d2);
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < n; ++k) {
    const int tri = ix.sample_triangle[idx[k]];
    if (tri < 0) {
      best = std::min(best, std::sqrt(d2[k]));
      continue;
    }
    const Eigen::Vector3i& t = ix.triangles[tri];
    best = std::min(best, (p - closestPointOnTriangle(p, ix.vertices[t[0]], ix.vertices[t[1]], ix.vertices[t[2]])).norm());
  }
  return best;
}

double SurfaceDistance::vertexDistance(const Vec3d& p) const {
  std::uint32_t idx;
  double d2;
  index_->vertex_tree->knnSearch(p.data(), 1, &idx, &d2);
  return std::sqrt(d2);
}

void EvalConfig::validate() const {
  std::ostringstream msg;
  if (!(completeness_threshold_m > 0 && completeness_threshold_m <= 10))
    msg << "EvalConfig.completeness_threshold_m must be in (0, 10], got " << completeness_threshold_m;
  else if (!(sample_spacing_m > 0 && sample_spacing_m <= 1))
    msg << "EvalConfig.sample_spacing_m must be in (0, 1], got " << sample_spacing_m;
  if (!msg.str().empty()) throw std::invalid_argument(msg.str());
}

SurfaceEval evaluateSurface(const TriangleMesh& reconstruction, const TriangleMesh& ground_truth, const EvalConfig& config) {
  config.validate();
  if (reconstruction.vertices.empty()) throw std::invalid_argument("evaluateSurface: the reconstruction is empty");
  if (ground_truth.vertices.empty()) throw std::invalid_argument("evaluateSurface: the ground truth is empty");
  const SurfaceDistance gt(ground_truth, config.sample_spacing_m);
  const SurfaceDistance rec(reconstruction, config.sample_spacing_m);

  const std::size_t n = reconstruction.vertices.size();
  std::vector<double> err(n), v2v(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const Vec3d p = reconstruction.vertices[i].cast<double>();
      err[i] = gt.distance(p);
      v2v[i] = gt.vertexDistance(p);
    }
  });
  const std::vector<Vec3d>& gt_samples = gt.samples();
  std::vector<char> covered(gt_samples.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, gt_samples.size()), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i)
      covered[i] = rec.distance(gt_samples[i]) <= config.completeness_threshold_m;
  });

  SurfaceEval e;
  e.reconstructed_vertices = n;
  e.ground_truth_samples = gt_samples.size();
  double sq = 0, sum = 0, sum_v2v = 0;
  for (std::size_t i = 0; i < n; ++i) {
    sq += err[i] * err[i];
    sum += err[i];
    sum_v2v += v2v[i];
  }
  e.accuracy_rmse_m = std::sqrt(sq / double(n));
  e.accuracy_mean_m = sum / double(n);
  e.accuracy_vertex_to_vertex_mean_m = sum_v2v / double(n);
  std::nth_element(err.begin(), err.begin() + n / 2, err.end());
  e.accuracy_median_m = err[n / 2];
  e.completeness = double(std::count(covered.begin(), covered.end(), 1)) / double(std::max<std::size_t>(1, covered.size()));
  e.completeness_threshold_m = config.completeness_threshold_m;
  return e;
}

}  // namespace vdbmap
