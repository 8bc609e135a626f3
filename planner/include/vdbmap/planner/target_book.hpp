// The exploration manager's book of targets: failures counted against frontier clusters, the
// blacklist, and the target being flown to with what its visit is judged by.
//
// Failures are kept per frontier voxel, because a cluster changes its id whenever its voxels
// change: a cluster counts the median failure count of its voxels (it inherits the failures of
// the cluster most of its voxels belonged to), and is blacklisted at max_failures.
#pragma once

#include "vdbmap/planner/frontier.hpp"

#include <openvdb/math/Coord.h>

#include <cstddef>
#include <unordered_map>
#include <vector>

namespace vdbmap::planner {

/// How the end of a visit was judged.
struct VisitJudgement {
  bool failed = false;
  std::size_t judged_voxels = 0;  ///< frontier voxels judged: what the viewpoint saw, else the target's
  double gone_fraction = 1.0;     ///< of them, no longer frontier
};

class TargetBook {
 public:
  /// Throws std::invalid_argument unless 1 <= max_failures <= 100.
  explicit TargetBook(int max_failures);

  /// Failures counted against `cluster`: the median over its voxels.
  int failures(const FrontierCluster& cluster) const;
  bool isBlacklisted(const FrontierCluster& cluster) const { return failures(cluster) >= max_failures_; }
  /// One more failure against `cluster`: each of its voxels counts at least failures(cluster) + 1.
  void addFailure(const FrontierCluster& cluster);
  /// Every count drops to max_failures - 1: each blacklisted cluster gets one more try.
  void forgiveBlacklisted();
  /// Failures added over the book's life.
  std::size_t failuresAdded() const { return failures_added_; }

  /// The cluster being flown to (0: none).
  ClusterId target() const { return target_; }
  /// Flying to `cluster`; `promised`: its frontier samples that the viewpoint flown to saw when
  /// planned (a large cluster is seen in part from any one viewpoint).
  void setTarget(const FrontierCluster& cluster, std::vector<openvdb::Coord> promised);
  /// No target.
  void clearTarget();
  /// The fraction of the target's frontier voxels (when planned) no longer frontier; 1 with none.
  double coveredFraction(const FrontierMap& frontiers) const;
  /// A failure against the target (its voxels when planned); nothing without one.
  void addTargetFailure();
  /// The visit is over (the trajectory to the target ended): a failure when no more than
  /// `covered_fraction` of what its viewpoint saw (of its voxels, when it saw none) is no longer
  /// frontier: the target cannot be observed from there. Without a target, nothing is judged.
  VisitJudgement judgeVisit(const FrontierMap& frontiers, double covered_fraction);
  /// The index in `clusters` of the target: its cluster, or, when that was made anew (the map
  /// changed around it), the cluster holding most of its frontier voxels; clusters.size() when
  /// none holds any.
  std::size_t findTarget(const std::vector<ClusterId>& clusters, const FrontierMap& frontiers) const;

 private:
  /// failures() and addFailure() on a cluster's voxels.
  int failures(const std::vector<openvdb::Coord>& voxels) const;
  void addFailure(const std::vector<openvdb::Coord>& voxels);

  int max_failures_;
  std::unordered_map<openvdb::Coord, int, CoordHash> voxel_failures_;
  std::size_t failures_added_ = 0;
  ClusterId target_ = 0;
  std::vector<openvdb::Coord> target_voxels_;    ///< the target's frontier voxels when planned
  std::vector<openvdb::Coord> target_promised_;  ///< what its viewpoint saw of them
};

}  // namespace vdbmap::planner
