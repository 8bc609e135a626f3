#include "vdbmap/planner/viewpoint_history.hpp"
#include "vdbmap/field_check.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>
#include <string>

namespace vdbmap::planner {

void ViewpointHistoryConfig::validate() const {
  const FieldCheck check("ViewpointHistoryConfig");
  if (!(record_spacing_m >= 0.0 && record_spacing_m <= 100.0)) check.fail("record_spacing_m", "[0, 100]");
  if (!(record_yaw_step_rad > 0.0 && record_yaw_step_rad <= M_PI)) check.fail("record_yaw_step_rad", "(0, pi]");
}

ViewpointHistory::ViewpointHistory(const ViewpointHistoryConfig& params) : params_(params) { params_.validate(); }

bool ViewpointHistory::offer(const Vec3d& position_W, double yaw_rad, double stamp_s) {
  if (!position_W.allFinite() || !std::isfinite(yaw_rad) || !std::isfinite(stamp_s))
    throw std::invalid_argument("ViewpointHistory::offer: non-finite pose or stamp at t = " + std::to_string(stamp_s));
  if (last_offer_s_ && stamp_s < *last_offer_s_)
    throw std::invalid_argument("ViewpointHistory::offer: stamp " + std::to_string(stamp_s) +
                                " s is earlier than the previous one, " + std::to_string(*last_offer_s_) + " s");
  age_at_last_offer_s_ = driftAge_s(stamp_s);
  last_offer_s_ = stamp_s;
  if (!viewpoints_.empty()) {
    const FlownViewpoint& last = viewpoints_.back();
    const bool moved = (position_W - last.position_W).norm() >= params_.record_spacing_m;
    const bool turned = yawDistance(last.yaw_rad, yaw_rad) >= params_.record_yaw_step_rad;
    if (!moved && !turned) return false;
  }
  viewpoints_.push_back(FlownViewpoint{position_W, wrapAngle(yaw_rad), stamp_s, age_at_last_offer_s_});
  index_.add(position_W);
  return true;
}

double ViewpointHistory::driftAge_s(double now_s) const {
  if (!std::isfinite(now_s) || (last_offer_s_ && now_s < *last_offer_s_))
    throw std::invalid_argument("ViewpointHistory::driftAge_s: t = " + std::to_string(now_s) +
                                " s is not finite or before the last offer");
  return last_offer_s_ ? age_at_last_offer_s_ + (now_s - *last_offer_s_) : 0.0;
}

void ViewpointHistory::anchor(double matched_stamp_s, double now_s) {
  if (!std::isfinite(matched_stamp_s) || !(matched_stamp_s <= now_s))
    throw std::invalid_argument("ViewpointHistory::anchor: matched stamp " + std::to_string(matched_stamp_s) +
                                " s is not finite or after the loop closure at " + std::to_string(now_s) + " s");
  const double vehicle_age_s = driftAge_s(now_s);  // checks now_s
  const auto after = std::upper_bound(viewpoints_.begin(), viewpoints_.end(), matched_stamp_s,
                                      [](double t, const FlownViewpoint& v) { return t < v.stamp_s; });
  const double place_age_s = after == viewpoints_.begin()
                                 ? 0.0
                                 : std::prev(after)->drift_age_s + (matched_stamp_s - std::prev(after)->stamp_s);
  const double m = std::min(vehicle_age_s, place_age_s);
  const double span_s = now_s - matched_stamp_s;
  for (auto it = std::lower_bound(viewpoints_.begin(), viewpoints_.end(), matched_stamp_s,
                                  [](const FlownViewpoint&v, double t) { return v.stamp_s < t; });
       it != viewpoints_.end(); ++it) {
    const double bridge = span_s > 0.0 ? (it->stamp_s - matched_stamp_s) * (now_s - it->stamp_s) / span_s : 0.0;
    it->drift_age_s = std::min(it->drift_age_s, m + bridge);
  }
  age_at_last_offer_s_ = m;
  last_offer_s_ = now_s;
}

std::vector<std::size_t> ViewpointHistory::withinRadius(const Vec3d& p_W, double radius_m) const {
  return index_.withinRadius(p_W, radius_m);
}

void ViewpointHistory::correct(const std::function<FlatPose(const FlownViewpoint&)>& corrected) {
  std::vector<FlownViewpoint> moved = viewpoints_;
  std::vector<Vec3d> positions;
  positions.reserve(moved.size());
  for (FlownViewpoint& v : moved) {
    const FlatPose pose = corrected(v);
    if (!pose.position_W.allFinite() || !std::isfinite(pose.yaw_rad))
      throw std::invalid_argument("ViewpointHistory::correct: non-finite corrected pose for the viewpoint at t = " +
                                  std::to_string(v.stamp_s));
    v.position_W = pose.position_W;
    v.yaw_rad = wrapAngle(pose.yaw_rad);
    positions.push_back(v.position_W);
  }
  index_.reset(positions);  // only after every pose was checked: a throw leaves the history as it was
  viewpoints_ = std::move(moved);
}

}  // namespace vdbmap::planner
