#include "vdbmap/sim/depth_camera.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

namespace vdbmap::sim {

void DepthCameraConfig::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("DepthCameraConfig." + what); };
  intrinsics.validate();
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0)) fail("rate_hz must be in (0, 1000]");
  if (!(max_range_m > 0.0 && max_range_m <= 1000.0)) fail("max_range_m must be in (0, 1000]");
  if (!(min_range_m >= 0.0 && min_range_m < max_range_m)) fail("min_range_m must be in [0, max_range_m)");
  if (!(depth_scale_m > 0.0 && depth_scale_m <= 0.1)) fail("depth_scale_m must be in (0, 0.1]");
  if (!(far_clip_m >= max_range_m && far_clip_m <= 65535.0 * depth_scale_m))
    fail("far_clip_m must be in [max_range_m, 65535 * depth_scale_m] (the 16-bit PNG range)");
  if (!(noise_sigma_m >= 0.0 && noise_sigma_m <= 1.0)) fail("noise_sigma_m must be in [0, 1]");
}

namespace {
/// SplitMix64: a counter-based generator, so noise depends only on (seed, frame, pixel).
std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}
double uniform01(std::uint64_t bits) { return (double(bits >> 11) + 0.5) * 0x1.0p-53; }  // in (0, 1)

/// A standard normal sample by Box-Muller from hashed counters.
double gaussian(std::uint64_t seed, std::uint64_t frame, std::uint64_t pixel) {
  const std::uint64_t k = splitmix64(seed ^ splitmix64(frame ^ splitmix64(pixel)));
  const double u1 = uniform01(splitmix64(k)), u2 = uniform01(splitmix64(k + 1));
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

/// Triangles behind this plane (camera z, metres) are clipped; depths below min_range_m are
/// rendered too (they occlude what is behind) and invalidated afterwards.
constexpr double kNearPlane = 1e-3;
constexpr int kBandRows = 16;

/// A triangle projected into the image, ready to rasterize.
struct ScreenTriangle {
  std::array<double, 3> x, y;  ///< pixel coordinates of the corners
  Vec3d n_S;                   ///< plane of the (unclipped) triangle in the camera frame: n . p = n_dot
  double n_dot;
  int u0, u1, v0, v1;  ///< pixel box (inclusive, clamped to the image)
};

/// Edge functions evaluated in a canonical orientation (endpoints in lexicographic order), so
/// two triangles sharing an edge evaluate it bit for bit alike; a pixel exactly on it belongs to
/// the triangle on its positive side. This makes the rasterization watertight.
struct Edge {
  double xa, ya, dx, dy;
  bool interior_positive;
  double eval(double px, double py) const { return dx * (py - ya) - dy * (px - xa); }
  bool inside(double px, double py) const {
    const double e = eval(px, py);
    return interior_positive ? e >= 0.0 : e < 0.0;
  }
};

Edge makeEdge(double x0, double y0, double x1, double y1, double x_other, double y_other) {
  if (x1 < x0 || (x1 == x0 && y1 < y0)) std::swap(x0, x1), std::swap(y0, y1);
  Edge e{x0, y0, x1 - x0, y1 - y0, true};
  e.interior_positive = e.eval(x_other, y_other) > 0.0;
  return e;
}

/// Projects a camera-frame polygon (already clipped to z >= kNearPlane) triangle by triangle.
void emit(const std::vector<Vec3d>& poly, const Vec3d& n_S, double n_dot, const CameraIntrinsics& K,
          std::vector<ScreenTriangle>& out) {
  for (std::size_t k = 2; k < poly.size(); ++k) {
    ScreenTriangle s;
    const Vec3d* c[3] = {&poly[0], &poly[k - 1], &poly[k]};
    double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
    for (int i = 0; i < 3; ++i) {
      s.x[std::size_t(i)] = K.fx * c[i]->x() / c[i]->z() + K.cx;
      s.y[std::size_t(i)] = K.fy * c[i]->y() / c[i]->z() + K.cy;
      xmin = std::min(xmin, s.x[std::size_t(i)]), xmax = std::max(xmax, s.x[std::size_t(i)]);
      ymin = std::min(ymin, s.y[std::size_t(i)]), ymax = std::max(ymax, s.y[std::size_t(i)]);
    }
    if (!(xmax >= 0.0 && ymax >= 0.0 && xmin <= K.width - 1 && ymin <= K.height - 1)) continue;
    s.u0 = std::max(0, int(std::ceil(xmin))), s.u1 = std::min(K.width - 1, int(std::floor(xmax)));
    s.v0 = std::max(0, int(std::ceil(ymin))), s.v1 = std::min(K.height - 1, int(std::floor(ymax)));
    if (s.u0 > s.u1 || s.v0 > s.v1) continue;  // covers no pixel centre
    s.n_S = n_S;
    s.n_dot = n_dot;
    out.push_back(s);
  }
}

/// Sutherland-Hodgman against z >= kNearPlane.
std::vector<Vec3d> clipNear(const std::array<Vec3d, 3>& tri) {
  std::vector<Vec3d> out;
  for (int i = 0; i < 3; ++i) {
    const Vec3d& p = tri[std::size_t(i)];
    const Vec3d& q = tri[std::size_t((i + 1) % 3)];
    const bool p_in = p.z() >= kNearPlane, q_in = q.z() >= kNearPlane;
    if (p_in) out.push_back(p);
    if (p_in != q_in) out.push_back(p + (q - p) * ((kNearPlane - p.z()) / (q.z() - p.z())));
  }
  return out;
}

/// Narrows the pixel span [lo, hi] of a row to the pixels inside edge e; empty when lo > hi. Along a
/// row, e.eval is a monotone function of px (each rounded operation is), so the pixels inside one
/// edge are a prefix or a suffix of the row and binary search finds exactly the pixels the
/// pixel-by-pixel test accepts.
void narrowToEdge(const Edge& e, double py, int& lo, int& hi) {
  if (lo > hi) return;
  if (e.dy == 0.0) {  // constant along the row
    if (!e.inside(lo, py)) lo = hi + 1;
    return;
  }
  const bool prefix = (e.dy > 0.0) == e.interior_positive;  // eval falls along the row iff dy > 0
  if (prefix) {
    if (!e.inside(lo, py)) {
      lo = hi + 1;
      return;
    }
    int a = lo, b = hi;  // inside(a); find the last inside
    while (a < b) {
      const int m = a + (b - a + 1) / 2;
      if (e.inside(m, py))
        a = m;
      else
        b = m - 1;
    }
    hi = a;
  } else {
    if (!e.inside(hi, py)) {
      lo = hi + 1;
      return;
    }
    int a = lo, b = hi;  // inside(b); find the first inside
    while (a < b) {
      const int m = a + (b - a) / 2;
      if (e.inside(m, py))
        b = m;
      else
        a = m + 1;
    }
    lo = b;
  }
}

/// Pixel spans narrower than this are tested pixel by pixel (the same pixels either way).
constexpr int kSearchSpanPx = 8;

void rasterize(const ScreenTriangle& s, const CameraIntrinsics& K, int row_begin, int row_end,
               std::vector<double>& zbuf) {
  const Edge e0 = makeEdge(s.x[0], s.y[0], s.x[1], s.y[1], s.x[2], s.y[2]);
  const Edge e1 = makeEdge(s.x[1], s.y[1], s.x[2], s.y[2], s.x[0], s.y[0]);
  const Edge e2 = makeEdge(s.x[2], s.y[2], s.x[0], s.y[0], s.x[1], s.y[1]);
  const int v_begin = std::max(s.v0, row_begin), v_end = std::min(s.v1, row_end - 1);
  const bool search = s.u1 - s.u0 + 1 >= kSearchSpanPx;
  for (int v = v_begin; v <= v_end; ++v) {
    const double py = v, ray_y = (py - K.cy) / K.fy;
    double* row = &zbuf[std::size_t(v - row_begin) * std::size_t(K.width)];
    int lo = s.u0, hi = s.u1;
    if (search) {
      narrowToEdge(e0, py, lo, hi);
      narrowToEdge(e1, py, lo, hi);
      narrowToEdge(e2, py, lo, hi);
    }
    for (int u = lo; u <= hi; ++u) {
      const double px = u;
      if (!search && (!e0.inside(px, py) || !e1.inside(px, py) || !e2.inside(px, py))) continue;
      // Depth where the pixel's ray (z = 1) meets the triangle's plane: exact, not interpolated.
      const double den = s.n_S.x() * (px - K.cx) / K.fx + s.n_S.y() * ray_y + s.n_S.z();
      if (den == 0.0) continue;
      const double z = s.n_dot / den;
      if (z > 0.0 && z < row[u]) row[u] = z;
    }
  }
}
}  // namespace

DepthCamera::DepthCamera(const DepthCameraConfig& config) : config_(config) { config_.validate(); }

DepthImage DepthCamera::render(const World& world, const Pose3d& T_W_S, std::uint64_t frame) const {
  const CameraIntrinsics& K = config_.intrinsics;
  const TriangleMesh& mesh = world.mesh();
  const Pose3d T_S_W = T_W_S.inverse();

  // 1. Every vertex into the camera frame.
  std::vector<Vec3d> v_S(mesh.vertices.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, v_S.size(), 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) v_S[i] = T_S_W * mesh.vertices[i].cast<double>();
  });

  // 2. Cull, clip at the near plane and project every triangle.
  const double far = config_.far_clip_m;
  tbb::enumerable_thread_specific<std::vector<ScreenTriangle>> local;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.triangles.size(), 4096), [&](const auto& r) {
    std::vector<ScreenTriangle>& out = local.local();
    for (std::size_t t = r.begin(); t != r.end(); ++t) {
      const Eigen::Vector3i& idx = mesh.triangles[t];
      const std::array<Vec3d, 3> c = {v_S[std::size_t(idx[0])], v_S[std::size_t(idx[1])], v_S[std::size_t(idx[2])]};
      const double zmin = std::min({c[0].z(), c[1].z(), c[2].z()});
      if (zmin > far || std::max({c[0].z(), c[1].z(), c[2].z()}) < kNearPlane) continue;
      const Vec3d n_S = (c[1] - c[0]).cross(c[2] - c[0]);
      const double n_dot = n_S.dot(c[0]);
      if (n_dot == 0.0) continue;  // seen edge-on: covers no pixel
      if (zmin >= kNearPlane) {
        emit({c[0], c[1], c[2]}, n_S, n_dot, K, out);
      } else {
        const std::vector<Vec3d> poly = clipNear(c);
        if (poly.size() >= 3) emit(poly, n_S, n_dot, K, out);
      }
    }
  });
  // 3. Bin by bands of rows, then rasterize band by band (each band owns its rows, so no two
  // threads write a pixel).
  const int bands = (K.height + kBandRows - 1) / kBandRows;
  std::vector<std::vector<const ScreenTriangle*>> binned{std::size_t(bands)};
  for (const auto& v : local)
    for (const ScreenTriangle& s : v)
      for (int b = s.v0 / kBandRows; b <= s.v1 / kBandRows; ++b) binned[std::size_t(b)].push_back(&s);
  DepthImage image(K.width, K.height, 0.0f);
  tbb::parallel_for(0, bands, [&](int b) {
    const int row_begin = b * kBandRows, row_end = std::min(K.height, row_begin + kBandRows);
    std::vector<double> zbuf(std::size_t(row_end - row_begin) * std::size_t(K.width),
                             std::numeric_limits<double>::infinity());
    for (const ScreenTriangle* s : binned[std::size_t(b)]) rasterize(*s, K, row_begin, row_end, zbuf);
    for (int v = row_begin; v < row_end; ++v)
      for (int u = 0; u < K.width; ++u) {
        double z = zbuf[std::size_t(v - row_begin) * std::size_t(K.width) + std::size_t(u)];
        if (!std::isfinite(z)) continue;
        if (config_.noise_sigma_m > 0.0)
          z += config_.noise_sigma_m *
               gaussian(config_.noise_seed, frame, std::uint64_t(v) * std::uint64_t(K.width) + std::uint64_t(u));
        if (z >= config_.min_range_m && z <= far) image.at(u, v) = float(z);
      }
  });
  return image;
}

DepthImage DepthCamera::renderByRaycast(const World& world, const Pose3d& T_W_S) const {
  const CameraIntrinsics& K = config_.intrinsics;
  DepthImage image(K.width, K.height, 0.0f);
  const Eigen::Matrix3d R = T_W_S.linear();
  const Vec3d origin = T_W_S.translation();
  tbb::parallel_for(tbb::blocked_range<int>(0, K.height, 4), [&](const tbb::blocked_range<int>& rows) {
    for (int v = rows.begin(); v != rows.end(); ++v)
      for (int u = 0; u < K.width; ++u) {
        // Along the pixel's ray scaled to z = 1, the ray parameter over its length is the depth.
        const Vec3d ray_S((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
        const double len = ray_S.norm();
        const RayHit hit = world.raycast(origin, R * (ray_S / len), config_.far_clip_m * len);
        if (!hit.hit()) continue;
        const double z = hit.t / len;
        if (z >= config_.min_range_m && z <= config_.far_clip_m) image.at(u, v) = float(z);
      }
  });
  return image;
}

io::SensorInfo DepthCamera::sensorInfo() const {
  io::SensorInfo sensor;
  sensor.kind = io::SensorKind::Depth;
  sensor.intrinsics = config_.intrinsics;
  sensor.depth_scale = config_.depth_scale_m;
  sensor.min_range_m = config_.min_range_m;
  sensor.max_range_m = config_.max_range_m;
  return sensor;
}

}  // namespace vdbmap::sim
