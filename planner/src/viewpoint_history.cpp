#include "vdbmap/planner/viewpoint_history.hpp"
#include "vdbmap/field_check.hpp"

#include <cmath>
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
  last_offer_s_ = stamp_s;
  if (!viewpoints_.empty()) {
    const FlownViewpoint& last = viewpoints_.back();
    const bool moved = (position_W - last.position_W).norm() >= params_.record_spacing_m;
    const bool turned = yawDistance(last.yaw_rad, yaw_rad) >= params_.record_yaw_step_rad;
    if (!moved && !turned) return false;
  }
  viewpoints_.push_back(FlownViewpoint{position_W, wrapAngle(yaw_rad), stamp_s});
  index_.add(position_W);
  return true;
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
