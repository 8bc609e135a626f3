#include "vdbmap/sim/world.hpp"

#include "internal/triangle_bvh.hpp"
#include "vdbmap/io/mesh_io.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

namespace vdbmap::sim {

void WorldConfig::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("WorldConfig." + what); };
  if (std::isnan(ceiling_clip_z_m)) fail("ceiling_clip_z_m must be a height or +inf, got NaN");
  if (!(min_triangle_area_m2 >= 0.0 && min_triangle_area_m2 < 1.0)) fail("min_triangle_area_m2 must be in [0, 1)");
  if (cap_ceiling && !std::isfinite(ceiling_clip_z_m)) fail("cap_ceiling needs a finite ceiling_clip_z_m");
}

namespace {
double area(const Vec3d& a, const Vec3d& b, const Vec3d& c) { return 0.5 * (b - a).cross(c - a).norm(); }

/// Cuts a triangle by the half-space z <= z_max (Sutherland-Hodgman); 0, 3 or 4 vertices remain.
std::vector<Vec3d> clipBelow(const std::array<Vec3d, 3>& tri, double z_max) {
  std::vector<Vec3d> out;
  for (int i = 0; i < 3; ++i) {
    const Vec3d& p = tri[std::size_t(i)];
    const Vec3d& q = tri[std::size_t((i + 1) % 3)];
    const bool p_in = p.z() <= z_max, q_in = q.z() <= z_max;
    if (p_in) out.push_back(p);
    if (p_in != q_in) out.push_back(p + (q - p) * ((z_max - p.z()) / (q.z() - p.z())));
  }
  return out;
}
}  // namespace

World::World(const TriangleMesh& mesh, const WorldConfig& config) : config_(config) {
  config_.validate();
  stats_.triangles_in = mesh.triangles.size();
  const int n_vertices = int(mesh.vertices.size());
  // Keep the vertices shared (the renderer transforms each once per frame); clipping appends.
  mesh_.vertices = mesh.vertices;
  auto vertex = [&](const Vec3d& p) {
    mesh_.vertices.push_back(p.cast<float>());
    return int(mesh_.vertices.size()) - 1;
  };
  auto keep = [&](int ia, int ib, int ic) {
    const Vec3d a = mesh_.vertices[std::size_t(ia)].cast<double>(), b = mesh_.vertices[std::size_t(ib)].cast<double>(),
                c = mesh_.vertices[std::size_t(ic)].cast<double>();
    if (!(area(a, b, c) > config_.min_triangle_area_m2)) {
      ++stats_.degenerate_dropped;
      return;
    }
    mesh_.triangles.emplace_back(ia, ib, ic);
  };
  for (const Eigen::Vector3i& t : mesh.triangles) {
    if ((t.array() < 0).any() || (t.array() >= n_vertices).any()) {
      ++stats_.degenerate_dropped;
      continue;
    }
    const std::array<Vec3d, 3> v = {mesh.vertices[std::size_t(t[0])].cast<double>(),
                                    mesh.vertices[std::size_t(t[1])].cast<double>(),
                                    mesh.vertices[std::size_t(t[2])].cast<double>()};
    if (!v[0].allFinite() || !v[1].allFinite() || !v[2].allFinite()) {
      ++stats_.degenerate_dropped;
      continue;
    }
    if (std::max({v[0].z(), v[1].z(), v[2].z()}) <= config_.ceiling_clip_z_m) {
      keep(t[0], t[1], t[2]);
      continue;
    }
    const std::vector<Vec3d> poly = clipBelow(v, config_.ceiling_clip_z_m);
    if (poly.size() < 3) {
      ++stats_.clipped_away;
      continue;
    }
    std::vector<int> ids;
    for (const Vec3d& p : poly) ids.push_back(vertex(p));
    for (std::size_t k = 2; k < ids.size(); ++k) keep(ids[0], ids[k - 1], ids[k]);
  }
  if (config_.cap_ceiling && !mesh_.triangles.empty()) {
    Eigen::AlignedBox3d box;
    for (const Eigen::Vector3i& t : mesh_.triangles)
      for (int k = 0; k < 3; ++k) box.extend(mesh_.vertices[std::size_t(t[k])].cast<double>());
    const double z = config_.ceiling_clip_z_m;
    const int a = vertex({box.min().x(), box.min().y(), z}), b = vertex({box.max().x(), box.min().y(), z}),
              c = vertex({box.max().x(), box.max().y(), z}), d = vertex({box.min().x(), box.max().y(), z});
    mesh_.triangles.emplace_back(a, b, c);
    mesh_.triangles.emplace_back(a, c, d);
    stats_.capped = true;
  }
  stats_.triangles = mesh_.triangles.size();
  if (stats_.triangles == 0)
    throw std::invalid_argument("World: no usable triangle (of " + std::to_string(stats_.triangles_in) + ", " +
                                std::to_string(stats_.degenerate_dropped) + " degenerate, " +
                                std::to_string(stats_.clipped_away) + " above the ceiling clip)");
  std::vector<Vec3d> corners;
  corners.reserve(3 * mesh_.triangles.size());
  for (const Eigen::Vector3i& t : mesh_.triangles)
    for (int k = 0; k < 3; ++k) {
      corners.push_back(mesh_.vertices[std::size_t(t[k])].cast<double>());
      bounds_.extend(corners.back());
    }
  bvh_ = std::make_unique<internal::TriangleBvh>(corners);
  stats_.bvh_nodes = bvh_->nodes();
  stats_.bvh_depth = bvh_->depth();
}

World World::load(const std::filesystem::path& mesh_file, const WorldConfig& config) {
  const TriangleMesh mesh = io::readTriangleMesh(mesh_file);
  try {
    return World(mesh, config);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(mesh_file.string() + ": " + e.what());
  }
}

World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;
World::~World() = default;

RayHit World::raycast(const Vec3d& origin_W, const Vec3d& dir_W, double max_t) const {
  const internal::TriangleBvh::Hit h = bvh_->raycast(origin_W, dir_W, max_t);
  return {h.t, h.triangle};
}

double World::distance(const Vec3d& p_W, double max_distance_m) const {
  if (!(max_distance_m > 0.0)) return std::max(max_distance_m, 0.0);
  return std::sqrt(bvh_->distance2(p_W, max_distance_m * max_distance_m));
}

bool World::isSegmentClear(const Vec3d& a, const Vec3d& b, double clearance_m) const {
  if (!(clearance_m > 0.0)) throw std::invalid_argument("World::isSegmentClear: clearance_m must be > 0");
  const double length = (b - a).norm();
  const Vec3d dir = length > 0 ? Vec3d((b - a) / length) : Vec3d::UnitX();
  const double min_step = clearance_m / 20.0;
  for (double s = 0.0;;) {
    const double d = distance(a + s * dir, 2.0 * clearance_m);
    if (d < clearance_m) return false;
    if (s >= length) return true;
    s = std::min(s + std::max(d - clearance_m, min_step), length);
  }
}

}  // namespace vdbmap::sim
