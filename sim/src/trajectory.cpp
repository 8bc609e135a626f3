#include "vdbmap/sim/trajectory.hpp"

#include "vdbmap/atomic_file.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <string>

namespace vdbmap::sim {

Pose3d bodyPose(const Vec3d& position_W, double yaw_rad) {
  Pose3d T = Pose3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Vec3d::UnitZ()).toRotationMatrix();
  T.translation() = position_W;
  return T;
}

void MotionLimits::validate() const {
  auto check = [](double v, const char* name) {
    if (!(v > 0.0 && v <= 100.0))
      throw std::invalid_argument(std::string("MotionLimits.") + name + " must be in (0, 100]");
  };
  check(v_max_mps, "v_max_mps");
  check(a_max_mps2, "a_max_mps2");
  check(yaw_rate_max_radps, "yaw_rate_max_radps");
}

bool TrajectoryMaxima::within(const MotionLimits& limits, double tol) const {
  return speed_mps <= limits.v_max_mps * (1 + tol) && accel_mps2 <= limits.a_max_mps2 * (1 + tol) &&
         yaw_rate_radps <= limits.yaw_rate_max_radps * (1 + tol);
}

void SampledTrajectory::append(double t_s, const VehicleState& s) {
  if (!std::isfinite(t_s) || !s.position_W.allFinite() || !s.velocity_W.allFinite() || !s.acceleration_W.allFinite() ||
      !std::isfinite(s.yaw_rad) || !std::isfinite(s.yaw_rate_rad_s))
    throw std::invalid_argument("SampledTrajectory::append: non-finite state at t = " + std::to_string(t_s));
  if (!times_s_.empty() && !(t_s > times_s_.back()))
    throw std::invalid_argument("SampledTrajectory::append: time " + std::to_string(t_s) + " does not follow " +
                                std::to_string(times_s_.back()));
  times_s_.push_back(t_s);
  states_.push_back(s);
}

double SampledTrajectory::startTime() const {
  if (empty()) throw std::logic_error("SampledTrajectory::startTime: empty trajectory");
  return times_s_.front();
}
double SampledTrajectory::endTime() const {
  if (empty()) throw std::logic_error("SampledTrajectory::endTime: empty trajectory");
  return times_s_.back();
}

VehicleState SampledTrajectory::sample(double t) const {
  if (empty()) throw std::logic_error("SampledTrajectory::sample: empty trajectory");
  auto hover = [](VehicleState s) {
    s.velocity_W.setZero();
    s.acceleration_W.setZero();
    s.yaw_rate_rad_s = 0.0;
    return s;
  };
  if (t <= times_s_.front()) return t == times_s_.front() ? states_.front() : hover(states_.front());
  if (t >= times_s_.back()) return t == times_s_.back() ? states_.back() : hover(states_.back());
  const std::size_t i = std::size_t(std::upper_bound(times_s_.begin(), times_s_.end(), t) - times_s_.begin());
  const VehicleState& b = states_[i];
  const VehicleState& a = states_[i - 1];
  const double w = (t - times_s_[i - 1]) / (times_s_[i] - times_s_[i - 1]);
  VehicleState s;
  s.position_W = (1 - w) * a.position_W + w * b.position_W;
  s.velocity_W = (1 - w) * a.velocity_W + w * b.velocity_W;
  s.acceleration_W = (1 - w) * a.acceleration_W + w * b.acceleration_W;
  s.yaw_rad = (1 - w) * a.yaw_rad + w * b.yaw_rad;
  s.yaw_rate_rad_s = (1 - w) * a.yaw_rate_rad_s + w * b.yaw_rate_rad_s;
  return s;
}

double SampledTrajectory::length_m() const {
  double length = 0.0;
  for (std::size_t k = 1; k < states_.size(); ++k) length += (states_[k].position_W - states_[k - 1].position_W).norm();
  return length;
}

TrajectoryMaxima SampledTrajectory::maxima() const {
  TrajectoryMaxima m;
  Vec3d v_prev = Vec3d::Zero();
  double dt_prev = 0.0;
  for (std::size_t k = 1; k < states_.size(); ++k) {
    const double dt = times_s_[k] - times_s_[k - 1];
    const Vec3d v = (states_[k].position_W - states_[k - 1].position_W) / dt;
    m.speed_mps = std::max(m.speed_mps, v.norm());
    m.yaw_rate_radps = std::max(m.yaw_rate_radps, std::abs(states_[k].yaw_rad - states_[k - 1].yaw_rad) / dt);
    if (k > 1) m.accel_mps2 = std::max(m.accel_mps2, (v - v_prev).norm() / (0.5 * (dt + dt_prev)));
    v_prev = v;
    dt_prev = dt;
  }
  return m;
}

namespace {
/// One stop-to-stop move: a straight translation with a trapezoidal speed profile and a yaw
/// change at constant rate, both lasting `duration`.
struct Move {
  double t0 = 0.0, duration = 0.0;
  Vec3d p0 = Vec3d::Zero(), dir = Vec3d::UnitX();
  double length = 0.0, v_cruise = 0.0, accel = 0.0;
  double yaw0 = 0.0, dyaw = 0.0;

  VehicleState at(double t) const {
    const double tau = std::clamp(t - t0, 0.0, duration);
    const double t_acc = accel > 0.0 ? v_cruise / accel : 0.0;
    double s = 0.0, v = 0.0, a = 0.0;
    if (length > 0.0) {
      if (tau < t_acc) {
        s = 0.5 * accel * tau * tau, v = accel * tau, a = accel;
      } else if (tau <= duration - t_acc) {
        s = 0.5 * accel * t_acc * t_acc + v_cruise * (tau - t_acc), v = v_cruise;
      } else {
        const double r = duration - tau;
        s = length - 0.5 * accel * r * r, v = accel * r, a = -accel;
      }
    }
    VehicleState out;
    out.position_W = p0 + dir * std::min(s, length);
    out.velocity_W = dir * v;
    out.acceleration_W = dir * a;
    out.yaw_rad = yaw0 + dyaw * (duration > 0.0 ? tau / duration : 1.0);
    out.yaw_rate_rad_s = duration > 0.0 ? dyaw / duration : 0.0;
    return out;
  }
};

Move planMove(const FlatPose& from, const FlatPose& to, double yaw0, double dyaw, double t0, const MotionLimits& lim) {
  Move m;
  m.t0 = t0;
  m.p0 = from.position_W;
  m.length = (to.position_W - from.position_W).norm();
  if (m.length > 0.0) m.dir = (to.position_W - from.position_W) / m.length;
  m.yaw0 = yaw0;
  m.dyaw = dyaw;
  const double v = lim.v_max_mps, a = lim.a_max_mps2;
  const double t_move = m.length >= v * v / a ? m.length / v + v / a : 2.0 * std::sqrt(m.length / a);
  m.duration = std::max(t_move, std::abs(dyaw) / lim.yaw_rate_max_radps);
  m.accel = a;
  // Cruise speed of the trapezoid that covers `length` in `duration` with acceleration a: the
  // smaller root of v^2 / a - v T + L = 0 (equals v_max, or the triangle's peak, when T = t_move).
  const double disc = std::max(0.0, a * a * m.duration * m.duration - 4.0 * a * m.length);
  m.v_cruise = m.length > 0.0 ? 0.5 * (a * m.duration - std::sqrt(disc)) : 0.0;
  return m;
}
}  // namespace

SampledTrajectory timeParametrize(const std::vector<FlatPose>& path, const MotionLimits& limits, double dt_s,
                                  double start_time_s, bool shortest_yaw) {
  limits.validate();
  if (path.empty()) throw std::invalid_argument("timeParametrize: empty path");
  if (!(dt_s > 0.0 && dt_s <= 1.0)) throw std::invalid_argument("timeParametrize: dt_s must be in (0, 1]");
  for (const FlatPose& w : path)
    if (!w.position_W.allFinite() || !std::isfinite(w.yaw_rad))
      throw std::invalid_argument("timeParametrize: non-finite waypoint");
  std::vector<Move> moves;
  double t = start_time_s, yaw = path.front().yaw_rad;
  for (std::size_t i = 1; i < path.size(); ++i) {
    const double dyaw = shortest_yaw ? angleDifference(path[i].yaw_rad, yaw) : path[i].yaw_rad - path[i - 1].yaw_rad;
    const Move m = planMove(path[i - 1], path[i], yaw, dyaw, t, limits);
    if (m.duration <= 0.0) continue;  // the same waypoint twice
    moves.push_back(m);
    t += m.duration;
    yaw += dyaw;
  }
  SampledTrajectory trajectory;
  if (moves.empty()) {
    VehicleState only;
    only.position_W = path.front().position_W;
    only.yaw_rad = path.front().yaw_rad;
    trajectory.append(start_time_s, only);
    return trajectory;
  }
  // Samples on the dt grid, plus the exact end of every move, so the trajectory rests exactly
  // at each waypoint.
  for (const Move& m : moves) {
    const double m_end = m.t0 + m.duration;
    for (long k = long(std::ceil((m.t0 - start_time_s) / dt_s - 1e-9));; ++k) {
      const double tk = start_time_s + double(k) * dt_s;
      if (tk >= m_end - 1e-9) break;
      if (trajectory.empty() || tk > trajectory.endTime() + 1e-9) trajectory.append(tk, m.at(tk));
    }
    trajectory.append(m_end, m.at(m_end));
  }
  return trajectory;
}

std::vector<FlatPose> readWaypoints(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path.string() + ": cannot open the waypoint file");
  std::vector<FlatPose> out;
  std::vector<bool> has_yaw;
  std::string line;
  for (std::size_t number = 1; std::getline(in, line); ++number) {
    const std::size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    std::vector<double> values;
    std::string token;
    while (fields >> token) {
      try {
        std::size_t used = 0;
        values.push_back(std::stod(token, &used));
        if (used != token.size()) throw std::invalid_argument(token);
      } catch (const std::exception&) {
        throw std::runtime_error(path.string() + ":" + std::to_string(number) + ": '" + token + "' is not a number");
      }
      if (!std::isfinite(values.back()))
        throw std::runtime_error(path.string() + ":" + std::to_string(number) + ": non-finite value");
    }
    if (values.empty()) continue;
    if (values.size() != 3 && values.size() != 4)
      throw std::runtime_error(path.string() + ":" + std::to_string(number) +
                               ": expected 'x y z' or 'x y z yaw', got " + std::to_string(values.size()) + " numbers");
    out.push_back({Vec3d(values[0], values[1], values[2]), values.size() == 4 ? values[3] : 0.0});
    has_yaw.push_back(values.size() == 4);
  }
  if (out.empty()) throw std::runtime_error(path.string() + ": no waypoint in the file");
  double last_yaw = 0.0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (!has_yaw[i]) {
      const Vec3d d = i + 1 < out.size() ? Vec3d(out[i + 1].position_W - out[i].position_W) : Vec3d::Zero();
      out[i].yaw_rad = d.head<2>().norm() > 1e-9 ? std::atan2(d.y(), d.x()) : last_yaw;
    }
    last_yaw = out[i].yaw_rad;
  }
  return out;
}

void writeWaypoints(const std::filesystem::path& path, const std::vector<FlatPose>& waypoints) {
  vdbmap::writeFileAtomically(path, [&](std::ostream& os) {
    os << "# x y z yaw (metres, radians)\n" << std::setprecision(9);
    for (const FlatPose& w : waypoints)
      os << w.position_W.x() << " " << w.position_W.y() << " " << w.position_W.z() << " " << w.yaw_rad << "\n";
  });
}

}  // namespace vdbmap::sim
