// Loop-closing clusters (Zhang et al. 2022, Sect. IV-D): places in the viewpoint history the
// vehicle could fly back to so that its loop detector fires.
//
// Viewpoints join the clustering once they are min_age_s old (a younger place cannot close a
// loop: the detector needs an older frame, 15 s in the simulator, and the authors only consider
// pose-graph poses older than 20 s). Taken in flight order they form *runs* of consecutive
// viewpoints; a run ends before the viewpoint that
//   - jumps more than link_distance_m from the previous one (a gap, or a pose correction),
//   - would make it longer than max_viewpoints (the authors' cap: 20), or
//   - lies farther than max_extent_m from the run's first viewpoint,
// so that one run is one place and distinct places stay distinct. A completed run's centre is its
// middle viewpoint (a pose actually flown: free space and a real yaw, as the authors take it).
// If an existing cluster's centre lies within merge_distance_m of it (the authors: 2 m; a second
// pass through a place, or the next stretch of a slow flight), the run joins that cluster;
// otherwise it starts a new one. A cluster keeps its centre; its members are the centre and the
// viewpoints nearest to it, at most max_viewpoints: the alternatives that local refinement may
// pick instead of the centre (any old viewpoint can close a loop).
//
// The last run stays open until the next aged viewpoint ends it; it is not a cluster yet.
#pragma once

#include "vdbmap/planner/point_index.hpp"
#include "vdbmap/planner/viewpoint.hpp"
#include "vdbmap/planner/viewpoint_history.hpp"

#include <cstddef>
#include <optional>
#include <vector>

namespace vdbmap::planner {

struct LoopClusterConfig {
  /// Viewpoints younger than this are not clustered; [0, 1e6]. The authors' 20 s (their pose-graph
  /// filter), above the simulator's 15 s loop-detection age.
  double min_age_s = 20.0;
  int max_viewpoints = 20;        ///< the size bound of a run and of a cluster (authors: 20); [1, 10000]
  double max_extent_m = 1.0;      ///< a run's viewpoints lie within this of its first; (0, 100]
  double link_distance_m = 1.0;   ///< a larger step between consecutive viewpoints ends a run; (0, 100]
  double merge_distance_m = 2.0;  ///< runs with a centre this close join the cluster (authors: 2 m); [0, 100]
  void validate() const;
};
using LoopClusterParams [[deprecated("renamed LoopClusterConfig")]] = LoopClusterConfig;

/// A cluster's id is its index in LoopClusters::clusters(); clusters are never removed.
using LoopClusterId = std::size_t;

struct LoopCluster {
  LoopClusterId id = 0;
  std::size_t centre = 0;  ///< history index of the centre viewpoint (the middle of its first run)
  /// History indices: the centre first, then by distance to it (ties: older first); at most
  /// max_viewpoints.
  std::vector<std::size_t> members;
  std::size_t runs = 1;  ///< runs that formed it (1 + merged ones)
};

class LoopClusters {
 public:
  explicit LoopClusters(const LoopClusterConfig& params = {});

  /// Takes the viewpoints of `history` that are at least min_age_s old at now_s (and not taken
  /// before), in order, into runs; every completed run becomes a cluster or joins one. Returns the
  /// number of runs completed. Pass the same growing history every time; throws
  /// std::invalid_argument if it has fewer viewpoints than were taken already.
  std::size_t update(const ViewpointHistory& history, double now_s);

  /// After history.correct(): centres and member order follow the corrected positions (membership
  /// stays).
  void refresh(const ViewpointHistory& history);

  const std::vector<LoopCluster>& clusters() const { return clusters_; }
  std::size_t size() const { return clusters_.size(); }
  const LoopCluster& operator[](LoopClusterId id) const { return clusters_.at(id); }

  /// The cluster a history viewpoint belongs to; none while it is young or in the open run, or
  /// when the size bound left it out.
  std::optional<LoopClusterId> clusterOf(std::size_t viewpoint) const;

  /// Clusters with at least one member within radius_m of p_W (found through the history's
  /// KD-tree), ascending.
  std::vector<LoopClusterId> near(const ViewpointHistory& history, const Vec3d& p_W, double radius_m) const;

  /// A cluster's members as viewpoints, in member order (centre first); visible_samples is 0.
  std::vector<Viewpoint> viewpoints(const ViewpointHistory& history, LoopClusterId id) const;

  std::size_t taken() const { return cluster_of_.size(); }          ///< history viewpoints taken so far
  const std::vector<std::size_t>& openRun() const { return run_; }  ///< history indices of the open run
  const LoopClusterConfig& params() const { return params_; }

 private:
  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);

  bool extendsRun(const ViewpointHistory& history, std::size_t i) const;
  void closeRun(const ViewpointHistory& history);
  void sortMembers(const ViewpointHistory& history, LoopCluster& cluster) const;

  LoopClusterConfig params_;
  std::vector<LoopCluster> clusters_;
  PointIndex centres_;                   ///< centre positions; index = cluster id
  std::vector<std::size_t> cluster_of_;  ///< per taken history viewpoint: its cluster or kNone
  std::vector<std::size_t> run_;         ///< the open run
};

}  // namespace vdbmap::planner
