#include "vdbmap/planner/loop_clusters.hpp"
#include "vdbmap/field_check.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace vdbmap::planner {

void LoopClusterConfig::validate() const {
  const FieldCheck check("LoopClusterConfig");
  if (!(min_age_s >= 0.0 && min_age_s <= 1e6)) check.fail("min_age_s", "[0, 1e6]");
  if (max_viewpoints < 1 || max_viewpoints > 10000) check.fail("max_viewpoints", "[1, 10000]");
  if (!(max_extent_m > 0.0 && max_extent_m <= 100.0)) check.fail("max_extent_m", "(0, 100]");
  if (!(link_distance_m > 0.0 && link_distance_m <= 100.0)) check.fail("link_distance_m", "(0, 100]");
  if (!(merge_distance_m >= 0.0 && merge_distance_m <= 100.0)) check.fail("merge_distance_m", "[0, 100]");
}

LoopClusters::LoopClusters(const LoopClusterConfig& params) : params_(params) { params_.validate(); }

std::size_t LoopClusters::update(const ViewpointHistory& history, double now_s) {
  if (history.size() < cluster_of_.size())
    throw std::invalid_argument("LoopClusters::update: the history has " + std::to_string(history.size()) +
                                " viewpoints, " + std::to_string(cluster_of_.size()) + " were taken already");
  std::size_t completed = 0;
  const double newest_s = now_s - params_.min_age_s;
  for (std::size_t i = cluster_of_.size(); i < history.size() && history[i].stamp_s <= newest_s; ++i) {
    cluster_of_.push_back(kNone);
    if (!run_.empty() && !extendsRun(history, i)) {
      closeRun(history);
      ++completed;
    }
    run_.push_back(i);
  }
  return completed;
}

bool LoopClusters::extendsRun(const ViewpointHistory& history, std::size_t i) const {
  const Vec3d& p = history[i].position_W;
  return (p - history[run_.back()].position_W).norm() <= params_.link_distance_m &&
         int(run_.size()) < params_.max_viewpoints &&
         (p - history[run_.front()].position_W).norm() <= params_.max_extent_m;
}

void LoopClusters::closeRun(const ViewpointHistory& history) {
  const std::size_t middle = run_[run_.size() / 2];
  const Vec3d& centre_W = history[middle].position_W;

  // Join the nearest cluster whose centre is within the merge distance (ties: the older cluster).
  std::optional<LoopClusterId> join;
  double best = 0.0;
  for (const std::size_t id : centres_.withinRadius(centre_W, params_.merge_distance_m)) {
    const double d = (centres_[id] - centre_W).norm();
    if (!join || d < best) join = id, best = d;
  }

  LoopCluster* cluster;
  if (join) {
    cluster = &clusters_[*join];
    cluster->members.insert(cluster->members.end(), run_.begin(), run_.end());
    ++cluster->runs;
  } else {
    clusters_.push_back(LoopCluster{clusters_.size(), middle, run_, 1});
    centres_.add(centre_W);
    cluster = &clusters_.back();
  }
  sortMembers(history, *cluster);
  // Members beyond the size bound leave the cluster (the farthest from the centre).
  for (std::size_t k = std::size_t(params_.max_viewpoints); k < cluster->members.size(); ++k)
    cluster_of_[cluster->members[k]] = kNone;
  if (cluster->members.size() > std::size_t(params_.max_viewpoints))
    cluster->members.resize(std::size_t(params_.max_viewpoints));
  for (const std::size_t m : cluster->members) cluster_of_[m] = cluster->id;
  run_.clear();
}

void LoopClusters::sortMembers(const ViewpointHistory& history, LoopCluster& cluster) const {
  const Vec3d& c = history[cluster.centre].position_W;
  auto& m = cluster.members;
  std::iter_swap(m.begin(), std::find(m.begin(), m.end(), cluster.centre));
  std::sort(m.begin() + 1, m.end(), [&](std::size_t a, std::size_t b) {
    const double da = (history[a].position_W - c).squaredNorm(), db = (history[b].position_W - c).squaredNorm();
    return da != db ? da < db : a < b;
  });
}

void LoopClusters::refresh(const ViewpointHistory& history) {
  if (history.size() < cluster_of_.size())
    throw std::invalid_argument("LoopClusters::refresh: the history has fewer viewpoints than were clustered");
  std::vector<Vec3d> centres;
  centres.reserve(clusters_.size());
  for (LoopCluster& cluster : clusters_) {
    sortMembers(history, cluster);
    centres.push_back(history[cluster.centre].position_W);
  }
  centres_.reset(centres);
}

std::optional<LoopClusterId> LoopClusters::clusterOf(std::size_t viewpoint) const {
  if (viewpoint >= cluster_of_.size() || cluster_of_[viewpoint] == kNone) return std::nullopt;
  return cluster_of_[viewpoint];
}

std::vector<LoopClusterId> LoopClusters::near(const ViewpointHistory& history, const Vec3d& p_W,
                                              double radius_m) const {
  std::vector<LoopClusterId> ids;
  for (const std::size_t i : history.withinRadius(p_W, radius_m))
    if (const auto id = clusterOf(i)) ids.push_back(*id);
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

std::vector<Viewpoint> LoopClusters::viewpoints(const ViewpointHistory& history, LoopClusterId id) const {
  std::vector<Viewpoint> views;
  for (const std::size_t m : clusters_.at(id).members)
    views.push_back(Viewpoint{history[m].position_W, history[m].yaw_rad, 0});
  return views;
}

}  // namespace vdbmap::planner
