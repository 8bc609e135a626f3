#include "vdbmap/testing/analytic_scene.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace vdbmap::testing {
namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kMinT = 1e-9;

/// Entry and exit parameters of a ray through an axis-aligned box (slab method).
bool slab(const Vec3d& o, const Vec3d& d, const Vec3d& lo, const Vec3d& hi, double& t_in, double& t_out) {
  t_in = -kInf;
  t_out = kInf;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0.0) {
      if (o[a] < lo[a] || o[a] > hi[a]) return false;
      continue;
    }
    double t0 = (lo[a] - o[a]) / d[a], t1 = (hi[a] - o[a]) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    t_in = std::max(t_in, t0);
    t_out = std::min(t_out, t1);
  }
  return t_in <= t_out;
}

/// Signed distance to a solid box (negative inside).
double boxSdf(const Vec3d& p, const Vec3d& lo, const Vec3d& hi) {
  const Vec3d c = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
  const Vec3d q = (p - c).cwiseAbs() - h;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

double hit(const Primitive& s, const Vec3d& o, const Vec3d& d) {
  switch (s.kind) {
    case Primitive::Kind::Plane: {
      const double den = s.b.dot(d);
      if (den == 0.0) return kInf;
      const double t = s.b.dot(s.a - o) / den;
      return t > kMinT ? t : kInf;
    }
    case Primitive::Kind::Sphere: {
      const Vec3d oc = o - s.a;
      const double bq = oc.dot(d), c = oc.squaredNorm() - s.radius * s.radius;
      const double disc = bq * bq - c;
      if (disc < 0.0) return kInf;
      const double r = std::sqrt(disc);
      if (-bq - r > kMinT) return -bq - r;
      if (-bq + r > kMinT) return -bq + r;
      return kInf;
    }
    case Primitive::Kind::Box: {
      double t_in, t_out;
      if (!slab(o, d, s.a, s.b, t_in, t_out)) return kInf;
      if (t_in > kMinT) return t_in;
      return t_out > kMinT ? t_out : kInf;
    }
    case Primitive::Kind::Room: {
      double t_in, t_out;
      if (!slab(o, d, s.a, s.b, t_in, t_out)) return kInf;
      if (t_out > kMinT && t_in <= kMinT) return t_out;  // from inside: the far wall
      return t_in > kMinT ? t_in : kInf;
    }
  }
  return kInf;
}

double dist(const Primitive& s, const Vec3d& p) {
  switch (s.kind) {
    case Primitive::Kind::Plane: return std::abs(s.b.dot(p - s.a));
    case Primitive::Kind::Sphere: return std::abs((p - s.a).norm() - s.radius);
    case Primitive::Kind::Box:
    case Primitive::Kind::Room: return std::abs(boxSdf(p, s.a, s.b));
  }
  return kInf;
}
}  // namespace

AnalyticScene& AnalyticScene::addPlane(const Vec3d& point, const Vec3d& normal) {
  if (!(normal.norm() > 0.0)) throw std::invalid_argument("AnalyticScene::addPlane: normal must be non-zero");
  primitives_.push_back({Primitive::Kind::Plane, point, normal.normalized(), 0.0});
  return *this;
}
AnalyticScene& AnalyticScene::addSphere(const Vec3d& centre, double radius) {
  if (!(radius > 0.0)) throw std::invalid_argument("AnalyticScene::addSphere: radius must be > 0");
  primitives_.push_back({Primitive::Kind::Sphere, centre, Vec3d::Zero(), radius});
  return *this;
}
AnalyticScene& AnalyticScene::addBox(const Vec3d& lo, const Vec3d& hi) {
  if (!(hi.array() > lo.array()).all()) throw std::invalid_argument("AnalyticScene::addBox: max corner must exceed min corner");
  primitives_.push_back({Primitive::Kind::Box, lo, hi, 0.0});
  return *this;
}
AnalyticScene& AnalyticScene::addRoom(const Vec3d& lo, const Vec3d& hi) {
  if (!(hi.array() > lo.array()).all()) throw std::invalid_argument("AnalyticScene::addRoom: max corner must exceed min corner");
  primitives_.push_back({Primitive::Kind::Room, lo, hi, 0.0});
  return *this;
}

double AnalyticScene::raycast(const Vec3d& o, const Vec3d& d) const {
  double best = kInf;
  for (const Primitive& s : primitives_) best = std::min(best, hit(s, o, d));
  return best;
}

double AnalyticScene::distance(const Vec3d& p) const {
  double best = kInf;
  for (const Primitive& s : primitives_) best = std::min(best, dist(s, p));
  return best;
}

DepthImage AnalyticScene::renderDepth(const CameraIntrinsics& K, const Pose3d& T_W_S, double max_range_m) const {
  K.validate();
  DepthImage img(K.width, K.height, 0.0f);
  const Eigen::Matrix3d R = T_W_S.linear();
  const Vec3d o = T_W_S.translation();
  tbb::parallel_for(tbb::blocked_range<int>(0, K.height), [&](const tbb::blocked_range<int>& rows) {
    for (int v = rows.begin(); v != rows.end(); ++v) {
      for (int u = 0; u < K.width; ++u) {
        const Vec3d ray_S((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);  // z = 1: t along it is depth
        const double len = ray_S.norm();
        const double t = raycast(o, R * (ray_S / len));
        const double depth = t / len;
        if (std::isfinite(t) && t <= max_range_m) img.at(u, v) = float(depth);
      }
    }
  });
  return img;
}

AnalyticScene AnalyticScene::demoRoom() {
  AnalyticScene scene;
  scene.addRoom({-4.0, -3.0, 0.0}, {4.0, 3.0, 3.0})
      .addSphere({2.0, 1.2, 1.0}, 0.6)
      .addBox({-2.5, 1.0, 0.0}, {-1.5, 2.2, 1.5})
      .addBox({1.0, -2.5, 0.0}, {2.6, -1.8, 0.9})
      .addBox({-1.8, -2.0, 0.7}, {-0.6, -1.2, 0.78});
  return scene;
}

std::vector<Pose3d> AnalyticScene::demoTrajectory(int frames) {
  std::vector<Pose3d> poses;
  poses.reserve(std::size_t(std::max(frames, 0)));
  for (int i = 0; i < frames; ++i) {
    const double s = double(i) / std::max(frames, 1);
    const double angle = 2.0 * M_PI * s;
    const Vec3d p(1.2 * std::cos(angle), 0.8 * std::sin(angle), 1.2 + 0.2 * std::sin(3.0 * angle));
    // Look outward and slightly down, sweeping around the room twice as fast as the circle.
    poses.push_back(lookingPose(p, 2.0 * angle, 0.25));
  }
  return poses;
}

}  // namespace vdbmap::testing
