#include "vdbmap/planner/trajectory.hpp"
#include "vdbmap/field_check.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

namespace vdbmap::planner {

namespace {
constexpr double kMovingSpeed_m_s = 1e-3;     ///< slower than this counts as at rest
constexpr double kMinTurn_rad = 1e-6;         ///< straighter corners are dropped
constexpr double kReversal_rad = M_PI - 1e-3; ///< sharper corners are taken stopping
constexpr double kStartTolerance_m = 1e-3;
constexpr double kYawTrackStep_s = 0.01;  ///< the tracked yaw's sampling (TrajectoryConfig::yaw_along_travel)

/// A corner of the polyline and how it is taken.
struct Corner {
  double tangent_m = 0.0;  ///< distance from the vertex where the arc starts (0: stop at the vertex)
  bool stop = false;
};
}  // namespace

const char* toString(TrajectoryStatus s) {
  switch (s) {
    case TrajectoryStatus::Ok: return "ok";
    case TrajectoryStatus::StartVelocityReduced: return "start_velocity_reduced";
    case TrajectoryStatus::PathNotClear: return "path_not_clear";
  }
  return "?";
}

void TrajectoryConfig::validate() const {
  const FieldCheck check("TrajectoryConfig");
  if (!(v_max_m_s > 0.0 && v_max_m_s <= 100.0)) check.fail("v_max_m_s", "(0, 100]");
  if (!(a_max_m_s2 > 0.0 && a_max_m_s2 <= 100.0)) check.fail("a_max_m_s2", "(0, 100]");
  if (!(yaw_rate_max_rad_s > 0.0 && yaw_rate_max_rad_s <= 100.0)) check.fail("yaw_rate_max_rad_s", "(0, 100]");
  if (!(yaw_acc_max_rad_s2 > 0.0 && yaw_acc_max_rad_s2 <= 1000.0)) check.fail("yaw_acc_max_rad_s2", "(0, 1000]");
  if (!(normal_acc_share > 0.0 && normal_acc_share < 1.0)) check.fail("normal_acc_share", "(0, 1)");
  if (!(corner_fraction > 0.0 && corner_fraction <= 0.5)) check.fail("corner_fraction", "(0, 0.5]");
  if (!(ds_m > 0.0 && ds_m <= 1.0)) check.fail("ds_m", "(0, 1]");
  if (!(clearance_m >= 0.0 && clearance_m <= 5.0)) check.fail("clearance_m", "[0, 5]");
  if (!(check_step_m >= 0.0 && check_step_m <= 1.0)) check.fail("check_step_m", "[0, 1]");
  if (corner_shrink_steps < 0 || corner_shrink_steps > 30) check.fail("corner_shrink_steps", "[0, 30]");
  if (!(yaw_lead_s > 0.0 && yaw_lead_s <= 10.0)) check.fail("yaw_lead_s", "(0, 10]", yaw_lead_s);
  if (!(start_facing_rad >= 0.0 && start_facing_rad <= M_PI))
    check.fail("start_facing_rad", "[0, pi]", start_facing_rad);
  if (!(free_way_m >= 0.0)) check.fail("free_way_m", ">= 0", free_way_m);
}

// ---- sampling ----------------------------------------------------------------------------------

Trajectory Trajectory::hold(const Vec3d& p_W, double yaw_rad) {
  Trajectory t;
  t.end_W_ = p_W;
  t.corners_ = {p_W};
  t.yaw0_ = yaw_rad;
  return t;
}

void Trajectory::geometry(double s, Vec3d& p, Vec3d& tangent, Vec3d& curvature) const {
  auto it = std::upper_bound(pieces_.begin(), pieces_.end(), s, [](double v, const Piece& pc) { return v < pc.s0; });
  const Piece& pc = it == pieces_.begin() ? pieces_.front() : *std::prev(it);
  const double u = std::clamp(s - pc.s0, 0.0, pc.length);
  if (!pc.arc) {
    p = pc.p0 + pc.dir * u;
    tangent = pc.dir;
    curvature.setZero();
    return;
  }
  const double phi = u / pc.radius;
  const Vec3d radial = pc.e0 * std::cos(phi) + pc.e1 * std::sin(phi);
  p = pc.centre + pc.radius * radial;
  tangent = -pc.e0 * std::sin(phi) + pc.e1 * std::cos(phi);
  curvature = -radial / pc.radius;
}

Vec3d Trajectory::startVelocity() const {
  if (pieces_.empty()) return Vec3d::Zero();
  Vec3d p, tangent, curvature;
  geometry(0.0, p, tangent, curvature);
  return node_v_.front() * tangent;
}

void Trajectory::sampleYaw(double t, double& yaw, double& rate) const {
  if (!yaw_track_.empty()) {
    const std::size_t last = yaw_track_.size() - 1;
    const std::size_t i = std::min<std::size_t>(std::size_t(std::max(0.0, t / kYawTrackStep_s)), last);
    const double tau = std::clamp(t - double(i) * kYawTrackStep_s, 0.0, kYawTrackStep_s);
    const double r0 = yaw_rate_track_[i], r1 = i < last ? yaw_rate_track_[i + 1] : r0;
    const double acc = i < last ? (r1 - r0) / kYawTrackStep_s : 0.0;
    yaw = wrapAngle(yaw_track_[i] + r0 * tau + 0.5 * acc * tau * tau);
    rate = i < last ? r0 + acc * tau : 0.0;
    return;
  }
  const double sign = yaw_delta_ < 0.0 ? -1.0 : 1.0;
  const double total = std::abs(yaw_delta_);
  double angle = 0.0, w = 0.0;
  if (total > 0.0) {
    const double T = duration_s_, tr = yaw_ramp_s_;
    if (t < tr) {
      angle = 0.5 * yaw_acc_ * t * t;
      w = yaw_acc_ * t;
    } else if (t < T - tr) {
      angle = 0.5 * yaw_acc_ * tr * tr + yaw_peak_rate_ * (t - tr);
      w = yaw_peak_rate_;
    } else {
      const double left = std::max(0.0, T - t);
      angle = total - 0.5 * yaw_acc_ * left * left;
      w = yaw_acc_ * left;
    }
    angle = std::clamp(angle, 0.0, total);
  }
  yaw = wrapAngle(yaw0_ + sign * angle);
  rate = sign * w;
}

VehicleState Trajectory::sample(double t_s) const {
  VehicleState st;
  const double t = std::clamp(t_s, 0.0, duration_s_);
  sampleYaw(t, st.yaw_rad, st.yaw_rate_rad_s);
  if (pieces_.empty() || t >= motion_s_) {
    st.position_W = end_W_;
    return st;
  }
  if (t < node_t_.front()) {  // turning on the spot before the motion starts
    Vec3d tangent, curvature;
    geometry(0.0, st.position_W, tangent, curvature);
    return st;
  }
  // The grid interval holding t: constant tangential acceleration inside it.
  const std::size_t i =
      std::min<std::size_t>(std::upper_bound(node_t_.begin(), node_t_.end(), t) - node_t_.begin(), node_t_.size() - 1) - 1;
  const double ds = node_s_[i + 1] - node_s_[i];
  const double v0 = node_v_[i], v1 = node_v_[i + 1];
  const double a = (v1 * v1 - v0 * v0) / (2.0 * ds);
  const double tau = t - node_t_[i];
  const double v = std::clamp(v0 + a * tau, std::min(v0, v1), std::max(v0, v1));
  const double s = std::clamp(node_s_[i] + v0 * tau + 0.5 * a * tau * tau, node_s_[i], node_s_[i + 1]);
  Vec3d p, tangent, curvature;
  geometry(s, p, tangent, curvature);
  st.position_W = p;
  st.velocity_W = v * tangent;
  st.acceleration_W = a * tangent + v * v * curvature;
  return st;
}

// ---- construction ------------------------------------------------------------------------------

namespace {
/// A speed cap over the first `until_m` of the way: braking from the start speed (at the
/// tangential acceleration arcs allow, so that it holds anywhere) down to `speed_m_s`.
struct SlowStart {
  double speed_m_s = 0.0;
  double until_m = 0.0;
};
}  // namespace

/// Builds a Trajectory: lead-in, corner rounding with clearance checks, speed profile, yaw.
class TrajectoryBuilder {
 public:
  TrajectoryBuilder(const MapQuery& map, const TrajectoryConfig& p)
      : p_(p), probe_(map), step_(p.check_step_m > 0.0 ? p.check_step_m : 0.5 * map.voxelSize()) {}

  TrajectoryResult build(const std::vector<Vec3d>& path, const VehicleState& start, double goal_yaw) {
    TrajectoryResult result;
    std::vector<Vec3d> pts = cleanPolyline(path);
    for (std::size_t i = 1; i < pts.size(); ++i)
      if (!probe_.isSegmentClear(pts[i - 1], pts[i], p_.clearance_m)) return result;  // PathNotClear

    // The path as it is first, starting with the part of the vehicle's velocity along it; when
    // that does not reproduce the velocity (other direction, or braking needs more room),
    // lead-ins along the current velocity, shortest first, until one does. Else the candidate
    // whose start velocity is nearest the vehicle's wins.
    const Vec3d v0 = start.velocity_W.norm() > kMovingSpeed_m_s ? start.velocity_W : Vec3d::Zero();
    const double speed0 = v0.norm();
    auto mismatch = [&v0](const Trajectory& t) { return (t.startVelocity() - v0).norm(); };
    auto matches = [&](const Trajectory& t) { return mismatch(t) <= 1e-9 * std::max(1.0, speed0); };
    const double along = pts.size() > 1 ? std::max(0.0, v0.dot((pts[1] - pts[0]).normalized())) : 0.0;
    Trajectory best = assemble(pts, along);
    if (!matches(best)) {
      const Vec3d u = v0 / speed0;
      const double brake_m = speed0 * speed0 / (2.0 * p_.a_max_m_s2);
      // Lead-in lengths, and whether the lead-in corner's arc may start at the vehicle.
      std::vector<std::pair<double, bool>> leads;
      if (p_.lead_in_at_speed && pts.size() > 1)
        if (const std::optional<double> lead = leadInAtSpeed(pts[0], u, speed0, pts[1])) leads.push_back({*lead, true});
      for (const double f : {0.6, 1.2, 2.0, 3.0}) leads.push_back({f * brake_m, false});
      for (const auto& [length, arc_from_start] : leads) {
        const Vec3d q = pts.front() + u * std::max(length, 2.0 * step_);
        std::vector<Vec3d> with_lead = pts.size() == 1 ? std::vector<Vec3d>{pts[0], q, pts[0]} : pts;
        if (pts.size() > 1) with_lead.insert(with_lead.begin() + 1, q);
        if (!probe_.isSegmentClear(with_lead[0], with_lead[1], p_.clearance_m) ||
            !probe_.isSegmentClear(with_lead[1], with_lead[2], p_.clearance_m))
          continue;
        Trajectory t = assemble(cleanPolyline(with_lead), speed0, arc_from_start);
        if (mismatch(t) < mismatch(best)) best = std::move(t);
        if (matches(best)) break;
      }
    }
    const bool matched = matches(best);
    if (p_.yaw_along_travel && best.motion_s_ > 0.0) {
      trackYaw(best, start.yaw_rad, goal_yaw);
      if (speed0 > 0.0 && matched) slowUntilFacing(best, start.yaw_rad, goal_yaw);
    } else {
      fitYaw(best, start.yaw_rad, goal_yaw);
    }
    result.trajectory = std::move(best);
    result.status = matched ? TrajectoryStatus::Ok : TrajectoryStatus::StartVelocityReduced;
    return result;
  }

 private:
  /// Drops repeated points and points on a straight line between their neighbours.
  static std::vector<Vec3d> cleanPolyline(const std::vector<Vec3d>& in) {
    std::vector<Vec3d> out;
    for (const Vec3d& p : in)
      if (out.empty() || (p - out.back()).norm() > 1e-9) out.push_back(p);
    for (std::size_t i = 1; i + 1 < out.size();) {
      const Vec3d a = (out[i] - out[i - 1]).normalized(), b = (out[i + 1] - out[i]).normalized();
      if (std::acos(std::clamp(a.dot(b), -1.0, 1.0)) < kMinTurn_rad)
        out.erase(out.begin() + std::ptrdiff_t(i));
      else
        ++i;
    }
    return out;
  }

  /// TrajectoryConfig::lead_in_at_speed: the lead-in length L along the unit velocity `u` from
  /// `start` whose corner, rounded by an arc from `start` tangent to u, turns toward `next` at
  /// `speed` (radius speed^2 / a_n, 1 % wider): L = R tan(theta / 2), where the turn theta at the
  /// lead-in point grows with L (fixed-point steps to 1 mm). None near a reversal.
  std::optional<double> leadInAtSpeed(const Vec3d& start, const Vec3d& u, double speed, const Vec3d& next) const {
    const double radius = 1.01 * speed * speed / (p_.normal_acc_share * p_.a_max_m_s2);
    double lead = 0.0;
    for (int k = 0; k < 50 && lead < 1e3; ++k) {
      const Vec3d out = next - (start + u * lead);
      const double turn = std::acos(std::clamp(u.dot(out.normalized()), -1.0, 1.0));
      const double longer = radius * std::tan(0.5 * turn);
      if (std::abs(longer - lead) < 1e-3) return longer;
      lead = longer;
    }
    return std::nullopt;
  }

  bool arcClear(const Trajectory::Piece& arc) {
    const int n = std::max(1, int(std::ceil(arc.length / step_)));
    for (int k = 0; k <= n; ++k) {
      const double phi = arc.length * k / n / arc.radius;
      const Vec3d p = arc.centre + arc.radius * (arc.e0 * std::cos(phi) + arc.e1 * std::sin(phi));
      if (!probe_.isClear(p, p_.clearance_m + 0.5 * step_)) return false;
    }
    return true;
  }

  /// The arc that rounds corner `i` with tangent length T (unit directions in/out, turn theta).
  static Trajectory::Piece makeArc(const Vec3d& vertex, const Vec3d& u_in, const Vec3d& u_out, double theta, double T) {
    Trajectory::Piece arc;
    arc.arc = true;
    arc.radius = T / std::tan(0.5 * theta);
    const Vec3d inward = (u_out - u_out.dot(u_in) * u_in).normalized();
    const Vec3d a = vertex - u_in * T;
    arc.centre = a + inward * arc.radius;
    arc.e0 = -inward;
    arc.e1 = u_in;
    arc.length = arc.radius * theta;
    return arc;
  }

  /// Geometry (rounded corners, checked) and the time-optimal speed profile from speed v0.
  /// With `arc_from_start`, the first corner's arc may begin at pts[0] (a lead-in's whole length).
  Trajectory assemble(const std::vector<Vec3d>& pts, double v0, bool arc_from_start = false) {
    Trajectory traj;
    traj.corners_ = pts;
    traj.end_W_ = pts.back();
    if (pts.size() < 2) return traj;

    // Corners: rounded if the arc is clear, else halved, else a stop at the vertex.
    std::vector<Corner> corners(pts.size());
    std::vector<Trajectory::Piece> arcs(pts.size());
    for (std::size_t i = 1; i + 1 < pts.size(); ++i) {
      const Vec3d d_in = pts[i] - pts[i - 1], d_out = pts[i + 1] - pts[i];
      const Vec3d u_in = d_in.normalized(), u_out = d_out.normalized();
      const double theta = std::acos(std::clamp(u_in.dot(u_out), -1.0, 1.0));
      corners[i].stop = true;
      if (theta >= kReversal_rad) continue;
      double T = arc_from_start && i == 1 ? std::min(d_in.norm(), p_.corner_fraction * d_out.norm())
                                          : p_.corner_fraction * std::min(d_in.norm(), d_out.norm());
      for (int attempt = 0; attempt <= p_.corner_shrink_steps; ++attempt, T *= 0.5) {
        const Trajectory::Piece arc = makeArc(pts[i], u_in, u_out, theta, T);
        if (arcClear(arc)) {
          corners[i] = Corner{T, false};
          arcs[i] = arc;
          break;
        }
      }
    }

    // Pieces: line, arc, line, ... ; a stop corner splits two lines at the vertex.
    auto addLine = [&](const Vec3d& a, const Vec3d& b, bool stop) {
      const double len = (b - a).norm();
      if (len <= 1e-9) {
        if (stop && !traj.pieces_.empty()) traj.pieces_.back().stop_at_end = true;
        return;
      }
      Trajectory::Piece line;
      line.p0 = a;
      line.dir = (b - a) / len;
      line.length = len;
      line.stop_at_end = stop;
      traj.pieces_.push_back(line);
    };
    Vec3d cursor = pts.front();
    for (std::size_t i = 1; i < pts.size(); ++i) {
      const bool last = i + 1 == pts.size();
      if (last || corners[i].stop) {
        addLine(cursor, pts[i], true);
        cursor = pts[i];
        if (!last) ++traj.stop_corners_;
        continue;
      }
      const Vec3d u_in = (pts[i] - pts[i - 1]).normalized(), u_out = (pts[i + 1] - pts[i]).normalized();
      addLine(cursor, pts[i] - u_in * corners[i].tangent_m, false);
      traj.pieces_.push_back(arcs[i]);
      cursor = pts[i] + u_out * corners[i].tangent_m;
    }
    double s = 0.0;
    for (Trajectory::Piece& pc : traj.pieces_) {
      pc.s0 = s;
      s += pc.length;
    }
    profile(traj, v0);
    return traj;
  }

  /// Time-optimal speed on a grid (nodes at piece ends): forward pass accelerating, backward
  /// pass braking, each limited per interval; then node times.
  void profile(Trajectory& traj, double v0, const SlowStart& slow = {}) const {
    const double a_max = p_.a_max_m_s2;
    const double a_n = p_.normal_acc_share * a_max;
    const double a_t_arc = std::sqrt(1.0 - p_.normal_acc_share * p_.normal_acc_share) * a_max;
    std::vector<double> s_nodes{0.0}, limit2{v0 * v0}, a_t;  // limit2: upper bound of v^2 per node
    for (std::size_t k = 0; k < traj.pieces_.size(); ++k) {
      const Trajectory::Piece& pc = traj.pieces_[k];
      const int n = std::max(2, int(std::ceil(pc.length / p_.ds_m)));
      const double cap2 = pc.arc ? std::min(p_.v_max_m_s * p_.v_max_m_s, a_n * pc.radius) : p_.v_max_m_s * p_.v_max_m_s;
      limit2.back() = std::min(limit2.back(), cap2);  // the node before this piece bounds its first interval
      for (int j = 1; j <= n; ++j) {
        s_nodes.push_back(pc.s0 + pc.length * j / n);
        limit2.push_back(cap2);
        a_t.push_back(pc.arc ? a_t_arc : a_max);
      }
      if (pc.stop_at_end) limit2.back() = 0.0;
    }
    limit2.back() = 0.0;  // rest at the goal
    for (std::size_t i = 1; i < s_nodes.size() && s_nodes[i] <= slow.until_m; ++i)
      limit2[i] = std::min(limit2[i], std::max(slow.speed_m_s * slow.speed_m_s, v0 * v0 - 2.0 * a_t_arc * s_nodes[i]));
    const std::size_t m = s_nodes.size();
    std::vector<double> v2(limit2);
    for (std::size_t i = 0; i + 1 < m; ++i)
      v2[i + 1] = std::min(v2[i + 1], v2[i] + 2.0 * a_t[i] * (s_nodes[i + 1] - s_nodes[i]));
    for (std::size_t i = m - 1; i > 0; --i)
      v2[i - 1] = std::min(v2[i - 1], v2[i] + 2.0 * a_t[i - 1] * (s_nodes[i] - s_nodes[i - 1]));
    traj.node_s_ = s_nodes;
    traj.node_v_.resize(m);
    traj.node_t_.assign(m, 0.0);
    for (std::size_t i = 0; i < m; ++i) traj.node_v_[i] = std::sqrt(std::max(0.0, v2[i]));
    for (std::size_t i = 0; i + 1 < m; ++i) {
      const double sum = traj.node_v_[i] + traj.node_v_[i + 1];
      // Both ends at rest cannot happen: every piece has >= 2 intervals and only piece ends stop.
      traj.node_t_[i + 1] = traj.node_t_[i] + (sum > 0.0 ? 2.0 * (s_nodes[i + 1] - s_nodes[i]) / sum : 0.0);
    }
    traj.motion_s_ = traj.node_t_.back();
    traj.duration_s_ = traj.motion_s_;
  }

  /// Trapezoidal yaw-rate profile over max(motion time, shortest turn time).
  void fitYaw(Trajectory& traj, double yaw0, double goal_yaw) const {
    const double delta = wrapAngle(goal_yaw - yaw0);
    const double total = std::abs(delta);
    const double w = p_.yaw_rate_max_rad_s, alpha = p_.yaw_acc_max_rad_s2;
    const double turn_s = total >= w * w / alpha ? total / w + w / alpha : 2.0 * std::sqrt(total / alpha);
    const double T = std::max(traj.motion_s_, turn_s);
    traj.duration_s_ = T;
    traj.yaw0_ = yaw0;
    traj.yaw_delta_ = delta;
    traj.yaw_acc_ = alpha;
    if (total <= 0.0 || T <= 0.0) return;
    // The slowest trapezoid with acceleration alpha that turns `total` in T: peak rate
    // w_c = (alpha T - sqrt(alpha^2 T^2 - 4 alpha total)) / 2 <= w because T >= turn_s.
    const double disc = std::max(0.0, alpha * alpha * T * T - 4.0 * alpha * total);
    traj.yaw_peak_rate_ = std::min(w, 0.5 * (alpha * T - std::sqrt(disc)));
    traj.yaw_ramp_s_ = traj.yaw_peak_rate_ / alpha;
  }

  /// The shortest time to turn `angle` from rest to rest within the limits.
  double turnTime(double angle) const {
    const double w = p_.yaw_rate_max_rad_s, alpha = p_.yaw_acc_max_rad_s2, total = std::abs(angle);
    return total >= w * w / alpha ? total / w + w / alpha : 2.0 * std::sqrt(total / alpha);
  }

  /// TrajectoryConfig::yaw_along_travel: every kYawTrackStep_s, the yaw rate moves (by at most
  /// yaw_acc_max per second) toward the time-optimal rate to the target, sqrt(2 alpha |error|)
  /// capped at yaw_rate_max, so that it arrives at rest. The target is the direction to the
  /// position yaw_lead_s ahead (kept while that is vertical or at rest), until the motion left is
  /// no longer than the turn to the goal yaw; from then on the goal yaw, which the track ends
  /// within 1 mrad of (the discrete law settles to that, not to zero error).
  void trackYaw(Trajectory& traj, double yaw0, double goal_yaw) const {
    const double h = kYawTrackStep_s, w = p_.yaw_rate_max_rad_s, alpha = p_.yaw_acc_max_rad_s2;
    const auto step = [&](double target, double& yaw, double& rate) {
      const double error = wrapAngle(target - yaw);
      const double wanted = std::copysign(std::min(w, std::sqrt(2.0 * alpha * std::abs(error))), error);
      const double next = rate + std::clamp(wanted - rate, -alpha * h, alpha * h);
      yaw += 0.5 * (rate + next) * h;
      rate = next;
    };
    const Eigen::Vector2d way =
        (traj.sample(std::min(p_.yaw_lead_s, traj.motion_s_)).position_W - traj.sample(0.0).position_W).head<2>();
    const double heading = way.norm() > 0.01 ? std::atan2(way.y(), way.x()) : yaw0;
    if (traj.startVelocity().norm() == 0.0) {
      // From rest: the yaw faces the way (within start_facing_rad) after k steps. Until then the
      // vehicle may fly only as far as lets it stop within free_way_m: node i's stopping point
      // s + v^2 / (2 a_max) grows along the profile, so the last node within it bounds the time
      // the motion may take before it faces the way, and the rest of the k steps are waited.
      double yaw = yaw0, rate = 0.0;
      int k = 0;
      for (; k < 100000 && std::abs(wrapAngle(heading - yaw)) > p_.start_facing_rad; ++k) step(heading, yaw, rate);
      double unfaced_s = 0.0;
      for (std::size_t i = 0; i < traj.node_t_.size() && stopsWithinFreeWay(traj, i); ++i) unfaced_s = traj.node_t_[i];
      const int wait = std::max(0, k - int(std::floor(unfaced_s / h)));
      for (double& t : traj.node_t_) t += wait * h;
      traj.motion_s_ += wait * h;
    }
    const double T = traj.motion_s_;
    double yaw = yaw0, rate = 0.0, target = heading;
    bool to_goal = false;
    traj.yaw_track_ = {yaw};
    traj.yaw_rate_track_ = {rate};
    constexpr int kMaxSteps = 1000000;  // 10^4 s: a bound the tracker never reaches
    for (int k = 0; k < kMaxSteps; ++k) {
      const double t = k * h;
      if (!to_goal) {
        const Eigen::Vector2d ahead =
            (traj.sample(std::min(t + p_.yaw_lead_s, T)).position_W - traj.sample(std::min(t, T)).position_W).head<2>();
        if (ahead.norm() > 0.01) target = std::atan2(ahead.y(), ahead.x());
        to_goal = T - t <= turnTime(wrapAngle(goal_yaw - yaw)) + h || t >= T;
      }
      if (to_goal) target = goal_yaw;
      if (t >= T && std::abs(wrapAngle(target - yaw)) < 1e-3 && std::abs(rate) <= alpha * h) break;  // within 1 mrad
      step(target, yaw, rate);
      traj.yaw_track_.push_back(yaw);
      traj.yaw_rate_track_.push_back(rate);
    }
    traj.duration_s_ = std::max(T, double(traj.yaw_track_.size() - 1) * h);
  }

  /// Whether the vehicle faces the way (the yaw within start_facing_rad of the tracker's target)
  /// before its stopping point, s + v^2 / (2 a_max), passes free_way_m; checked at the grid nodes.
  bool facesInTime(const Trajectory& traj) const {
    const double T = traj.motion_s_;
    for (std::size_t i = 0; i < traj.node_t_.size(); ++i) {
      const VehicleState st = traj.sample(traj.node_t_[i]);
      const Eigen::Vector2d ahead =
          (traj.sample(std::min(traj.node_t_[i] + p_.yaw_lead_s, T)).position_W - st.position_W).head<2>();
      if (ahead.norm() > 0.01 &&
          std::abs(wrapAngle(std::atan2(ahead.y(), ahead.x()) - st.yaw_rad)) <= p_.start_facing_rad)
        return true;
      if (!stopsWithinFreeWay(traj, i)) return false;
    }
    return true;
  }

  /// Braking at a_max from grid node i stops within free_way_m: s + v^2 / (2 a_max) <= free_way_m.
  bool stopsWithinFreeWay(const Trajectory& traj, std::size_t i) const {
    const double v = traj.node_v_[i];
    return traj.node_s_[i] + v * v / (2.0 * p_.a_max_m_s2) <= p_.free_way_m;
  }

  /// TrajectoryConfig::free_way_m for a moving start, which cannot wait on the spot: the fastest
  /// cruise speed over the free way (to 1 % of v_max, by bisection) that lets the vehicle face the
  /// way in time. Left as it is when the vehicle cannot stop within the free way even now, or
  /// when crawling at 5 cm/s does not help either (a look stop along the way then brakes it).
  void slowUntilFacing(Trajectory& traj, double yaw0, double goal_yaw) const {
    if (facesInTime(traj)) return;
    const double v0 = traj.node_v_.front();
    if (!stopsWithinFreeWay(traj, 0)) return;
    const auto slowed = [&](double speed_m_s) {
      Trajectory t = traj;
      profile(t, v0, SlowStart{speed_m_s, p_.free_way_m});
      trackYaw(t, yaw0, goal_yaw);
      return t;
    };
    double lo = 0.05, hi = p_.v_max_m_s;
    Trajectory best = slowed(lo);
    if (!facesInTime(best)) return;
    while (hi - lo > 0.01 * p_.v_max_m_s) {
      const double mid = 0.5 * (lo + hi);
      Trajectory t = slowed(mid);
      if (facesInTime(t)) {
        lo = mid;
        best = std::move(t);
      } else {
        hi = mid;
      }
    }
    traj = std::move(best);
  }

  TrajectoryConfig p_;
  MapProbe probe_;
  double step_;
};

TrajectoryResult planTrajectory(const std::vector<Vec3d>& path_W, const VehicleState& start, double goal_yaw_rad,
                                const MapQuery& map, const TrajectoryConfig& params) {
  params.validate();
  if (path_W.empty()) throw std::invalid_argument("planTrajectory: the path is empty");
  if ((path_W.front() - start.position_W).norm() > kStartTolerance_m)
    throw std::invalid_argument("planTrajectory: the path starts " +
                                std::to_string((path_W.front() - start.position_W).norm()) +
                                " m from the vehicle (at most 1 mm allowed)");
  std::vector<Vec3d> path = path_W;
  path.front() = start.position_W;
  TrajectoryBuilder builder(map, params);
  return builder.build(path, start, goal_yaw_rad);
}

}  // namespace vdbmap::planner
