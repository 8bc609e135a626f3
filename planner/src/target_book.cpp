#include "vdbmap/planner/target_book.hpp"

#include "vdbmap/field_check.hpp"

#include <algorithm>
#include <unordered_set>

namespace vdbmap::planner {
namespace {
/// The fraction of `voxels` that are no longer frontier (1 when there are none).
double noLongerFrontierFraction(const FrontierMap& frontiers, const std::vector<openvdb::Coord>& voxels) {
  if (voxels.empty()) return 1.0;
  std::size_t gone = 0;
  for (const openvdb::Coord& v : voxels) gone += frontiers.isFrontier(v) ? 0 : 1;
  return double(gone) / double(voxels.size());
}
}  // namespace

TargetBook::TargetBook(int max_failures) : max_failures_(max_failures) {
  if (max_failures < 1 || max_failures > 100) FieldCheck("TargetBook").fail("max_failures", "[1, 100]", max_failures);
}

int TargetBook::failures(const FrontierCluster& cluster) const { return failures(cluster.voxels); }

void TargetBook::addFailure(const FrontierCluster& cluster) { addFailure(cluster.voxels); }

int TargetBook::failures(const std::vector<openvdb::Coord>& voxels) const {
  if (voxel_failures_.empty() || voxels.empty()) return 0;
  std::vector<int> counts;
  counts.reserve(voxels.size());
  for (const openvdb::Coord& v : voxels) {
    const auto it = voxel_failures_.find(v);
    counts.push_back(it == voxel_failures_.end() ? 0 : it->second);
  }
  const auto mid = counts.begin() + std::ptrdiff_t(counts.size() / 2);
  std::nth_element(counts.begin(), mid, counts.end());
  return *mid;
}

void TargetBook::addFailure(const std::vector<openvdb::Coord>& voxels) {
  const int count = failures(voxels) + 1;
  for (const openvdb::Coord& v : voxels) {
    int& f = voxel_failures_[v];
    f = std::max(f, count);
  }
  ++failures_added_;
}

void TargetBook::forgiveBlacklisted() {
  for (auto& [voxel, count] : voxel_failures_) count = std::min(count, max_failures_ - 1);
}

void TargetBook::setTarget(const FrontierCluster& cluster, std::vector<openvdb::Coord> promised) {
  target_ = cluster.id;
  target_voxels_ = cluster.voxels;
  target_promised_ = std::move(promised);
}

void TargetBook::clearTarget() {
  target_ = 0;
  target_voxels_.clear();
  target_promised_.clear();
}

double TargetBook::coveredFraction(const FrontierMap& frontiers) const {
  return noLongerFrontierFraction(frontiers, target_voxels_);
}

void TargetBook::addTargetFailure() {
  if (target_ == 0 || target_voxels_.empty()) return;
  addFailure(target_voxels_);
}

VisitJudgement TargetBook::judgeVisit(const FrontierMap& frontiers, double covered_fraction) {
  VisitJudgement v;
  if (target_ == 0 || target_voxels_.empty()) return v;
  const std::vector<openvdb::Coord>& judged = target_promised_.empty() ? target_voxels_ : target_promised_;
  v.judged_voxels = judged.size();
  v.gone_fraction = noLongerFrontierFraction(frontiers, judged);
  v.failed = v.gone_fraction <= covered_fraction;
  if (v.failed) addTargetFailure();
  return v;
}

std::size_t TargetBook::findTarget(const std::vector<ClusterId>& clusters, const FrontierMap& frontiers) const {
  for (std::size_t i = 0; i < clusters.size(); ++i)
    if (clusters[i] == target_) return i;
  const std::unordered_set<openvdb::Coord, CoordHash> voxels(target_voxels_.begin(), target_voxels_.end());
  std::size_t best = clusters.size(), best_count = 0;
  for (std::size_t i = 0; i < clusters.size(); ++i) {
    const FrontierCluster* c = frontiers.find(clusters[i]);
    if (!c) continue;
    std::size_t count = 0;
    for (const openvdb::Coord& v : c->voxels) count += voxels.count(v);
    if (count > best_count) best = i, best_count = count;
  }
  return best;
}

}  // namespace vdbmap::planner
