// Accuracy and completeness of a reconstructed surface against ground truth.
//
// accuracy: for every vertex of the reconstructed mesh (the zero level set of the map), the
//   distance to the ground-truth surface; RMSE (the paper's metric), mean and median.
// completeness: the fraction of the ground-truth surface (area-weighted samples) within
//   `completeness_threshold_m` of the reconstructed surface.
// Distances are real nearest-surface queries (SurfaceDistance): a KD-tree over surface samples
// finds candidate triangles, and exact point-to-triangle distances decide.
#pragma once

#include "vdbmap/triangle_mesh.hpp"
#include "vdbmap/types.hpp"

#include <memory>

namespace vdbmap {

/// Nearest-surface distance to a triangle mesh, or to a point cloud (a mesh without triangles).
class SurfaceDistance {
 public:
  /// `sample_spacing_m`: spacing of the surface samples that index the triangles; candidates are
  /// the triangles of the nearest samples, so the result is exact unless a closer triangle has
  /// none of its samples among them (possible only where triangles are far larger than the
  /// spacing and packed closer than it).
  SurfaceDistance(const TriangleMesh& mesh, double sample_spacing_m);
  ~SurfaceDistance();
  SurfaceDistance(SurfaceDistance&&) noexcept;

  double distance(const Vec3d& p) const;
  /// Distance to the nearest mesh vertex (nvblox's vertex-to-vertex metric).
  double vertexDistance(const Vec3d& p) const;
  /// Area-weighted samples of the surface (seeded, deterministic): the points that index it.
  const std::vector<Vec3d>& samples() const;

 private:
  struct Index;
  std::unique_ptr<Index> index_;
};

struct EvalConfig {
  double completeness_threshold_m = 0.1;  ///< usually 2 voxels; (0, 10]
  double sample_spacing_m = 0.02;         ///< ground-truth surface sampling; (0, 1]
  void validate() const;
};

struct SurfaceEval {
  std::size_t reconstructed_vertices = 0;
  std::size_t ground_truth_samples = 0;
  double accuracy_rmse_m = 0.0;
  double accuracy_mean_m = 0.0;
  double accuracy_median_m = 0.0;
  double accuracy_vertex_to_vertex_mean_m = 0.0;  ///< nvblox's metric: nearest ground-truth vertex
  double completeness = 0.0;
  double completeness_threshold_m = 0.0;
};

/// Compares a reconstruction (e.g. extractMesh of the map) with a ground-truth mesh or point
/// cloud. Throws std::invalid_argument when either is empty.
SurfaceEval evaluateSurface(const TriangleMesh& reconstruction, const TriangleMesh& ground_truth, const EvalConfig& config);

}  // namespace vdbmap
