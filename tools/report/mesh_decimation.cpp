#include "report/mesh_decimation.hpp"

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace vdbmap::report {
namespace {

struct CellKey {
  std::int64_t x, y, z;
  bool operator==(const CellKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct CellHash {
  std::size_t operator()(const CellKey& k) const {
    return std::size_t(k.x * 73856093) ^ std::size_t(k.y * 19349663) ^ std::size_t(k.z * 83492791);
  }
};

}  // namespace

TriangleMesh clusterVertices(const TriangleMesh& mesh, double cell_m) {
  if (!(cell_m > 0.0) || !std::isfinite(cell_m))
    throw std::invalid_argument("clusterVertices: cell_m must be positive and finite, got " + std::to_string(cell_m));
  std::unordered_map<CellKey, int, CellHash> cell_of;
  std::vector<int> cluster(mesh.vertices.size(), -1);
  std::vector<Eigen::Vector3d> sum;
  std::vector<int> count;
  const auto clusterOf = [&](int v) {
    if (cluster[std::size_t(v)] >= 0) return cluster[std::size_t(v)];
    const Vec3f& p = mesh.vertices[std::size_t(v)];
    const CellKey key{std::int64_t(std::floor(double(p.x()) / cell_m)), std::int64_t(std::floor(double(p.y()) / cell_m)),
                      std::int64_t(std::floor(double(p.z()) / cell_m))};
    const auto [it, added] = cell_of.try_emplace(key, int(sum.size()));
    if (added) {
      sum.emplace_back(Eigen::Vector3d::Zero());
      count.push_back(0);
    }
    sum[std::size_t(it->second)] += p.cast<double>();
    ++count[std::size_t(it->second)];
    return cluster[std::size_t(v)] = it->second;
  };
  TriangleMesh out;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const int a = clusterOf(t[0]), b = clusterOf(t[1]), c = clusterOf(t[2]);
    if (a != b && b != c && a != c) out.triangles.emplace_back(a, b, c);
  }
  out.vertices.reserve(sum.size());
  for (std::size_t i = 0; i < sum.size(); ++i) out.vertices.push_back((sum[i] / double(count[i])).cast<float>());
  // Clusters only reached by collapsed triangles stay as unused vertices: drop them.
  std::vector<int> used(out.vertices.size(), -1);
  TriangleMesh compact;
  for (Eigen::Vector3i& t : out.triangles)
    for (int k = 0; k < 3; ++k) {
      int& u = used[std::size_t(t[k])];
      if (u < 0) {
        u = int(compact.vertices.size());
        compact.vertices.push_back(out.vertices[std::size_t(t[k])]);
      }
      t[k] = u;
    }
  compact.triangles = std::move(out.triangles);
  return compact;
}

TriangleMesh decimateToBudget(const TriangleMesh& mesh, std::size_t max_triangles, double start_cell_m) {
  if (max_triangles < 1) throw std::invalid_argument("decimateToBudget: max_triangles must be at least 1");
  if (mesh.triangles.size() <= max_triangles) return mesh;
  for (double cell = start_cell_m;; cell *= 2.0) {
    TriangleMesh out = clusterVertices(mesh, cell);
    if (out.triangles.size() <= max_triangles) return out;
  }
}

}  // namespace vdbmap::report
