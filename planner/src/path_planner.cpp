#include "vdbmap/planner/path_planner.hpp"
#include "vdbmap/field_check.hpp"
#include "vdbmap/timing.hpp"

#include <ompl/base/MotionValidator.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/StateValidityChecker.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <string>
#include <unordered_set>

namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace vdbmap::planner {

namespace {

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

/// OMPL is process-global in two ways: its console (the library never prints, so it is silenced)
/// and its seed generator (seeded once; every RNG the planner relies on also gets a local seed).
void initOmpl(std::uint64_t seed) {
  static std::once_flag once;
  std::call_once(once, [seed] {
    ompl::msg::setLogLevel(ompl::msg::LOG_NONE);
    ompl::RNG::setSeed(std::uint_fast32_t(splitmix64(seed) & 0xffffffffu) | 1u);
  });
}

Vec3d toVec(const ob::State* s) {
  const auto* r = s->as<ob::RealVectorStateSpace::StateType>();
  return Vec3d(r->values[0], r->values[1], r->values[2]);
}

/// A uniform sampler with its own seed, so a query does not depend on earlier queries.
class SeededSampler : public ob::RealVectorStateSampler {
 public:
  SeededSampler(const ob::StateSpace* space, std::uint_fast32_t seed) : ob::RealVectorStateSampler(space) {
    rng_.setLocalSeed(seed);
  }
};

/// OMPL's simplifier with its own seed (its random shortcuts would otherwise use the global one).
class SeededSimplifier : public og::PathSimplifier {
 public:
  SeededSimplifier(const ob::SpaceInformationPtr& si, std::uint_fast32_t seed) : og::PathSimplifier(si) {
    rng_.setLocalSeed(seed);
  }
};

}  // namespace

const char* toString(PathStatus s) {
  switch (s) {
    case PathStatus::Straight: return "straight";
    case PathStatus::Planned: return "planned";
    case PathStatus::StartInvalid: return "start_invalid";
    case PathStatus::GoalInvalid: return "goal_invalid";
    case PathStatus::NoPath: return "no_path";
  }
  return "?";
}

const char* toString(PathSearch s) {
  switch (s) {
    case PathSearch::Sampling: return "sampling";
    case PathSearch::Grid: return "grid";
    case PathSearch::SamplingThenGrid: return "sampling_then_grid";
  }
  return "?";
}

void PathConfig::validate() const {
  const FieldCheck check("PathConfig");
  if (!(clearance_m >= 0.0 && clearance_m <= 5.0)) check.fail("clearance_m", "[0, 5]");
  if (!(check_step_m >= 0.0 && check_step_m <= 1.0)) check.fail("check_step_m", "[0, 1]");
  if (!(time_limit_s > 0.0 && time_limit_s <= 60.0)) check.fail("time_limit_s", "(0, 60]");
  if (max_iterations > 1'000'000'000u) check.fail("max_iterations", "[0, 1e9]");
  if (!(rrt_range_m >= 0.0 && rrt_range_m <= 1e3)) check.fail("rrt_range_m", "[0, 1000]");
  if (simplify_rounds < 0 || simplify_rounds > 100) check.fail("simplify_rounds", "[0, 100]");
  if (bounds_W && bounds_W->isEmpty()) check.fail("bounds_W", "non-empty boxes");
  grid.validate();
}

double polylineLength(const std::vector<Vec3d>& points) {
  double length = 0.0;
  for (std::size_t i = 1; i < points.size(); ++i) length += (points[i] - points[i - 1]).norm();
  return length;
}

/// The collision test, on the heap so that OMPL's callbacks survive moves of the PathPlanner.
struct PathPlanner::Checker {
  MapProbe probe;
  double clearance_m;
  double step_m;
  Eigen::AlignedBox3d bounds_W;

  Checker(const MapQuery& map, double clearance, double step, const Eigen::AlignedBox3d& bounds)
      : probe(map), clearance_m(clearance), step_m(step), bounds_W(bounds) {}
  bool isClear(const Vec3d& p) {
    if (!bounds_W.contains(p)) return false;
    const Key key{p.x(), p.y(), p.z()};
    if (clear.count(key)) return true;
    if (!probe.isClear(p, clearance_m)) return false;
    if (clear.size() >= kMaxClearPoints) clear.clear();
    clear.insert(key);
    return true;
  }
  /// MapProbe::isSegmentClear, each end's ball read once for the planner's life: a search checks
  /// every new edge from a tree node that an earlier check found clear, and the simplifier
  /// re-checks edges between the path's nodes.
  bool isSegmentClear(const Vec3d& a, const Vec3d& b) {
    return isClear(a) && isClear(b) && probe.isSegmentClearFromClearEnds(a, b, clearance_m);
  }

 private:
  /// Points found clear, by their exact coordinates (the map does not change while the planner
  /// is used); the set is emptied when it holds this many.
  static constexpr std::size_t kMaxClearPoints = std::size_t(1) << 16;
  using Key = std::array<double, 3>;
  struct KeyHash {
    std::size_t operator()(const Key& k) const {
      std::uint64_t h = 0;
      for (double v : k) {
        std::uint64_t bits;
        std::memcpy(&bits, &v, sizeof bits);
        h = splitmix64(h ^ bits);
      }
      return std::size_t(h);
    }
  };
  std::unordered_set<Key, KeyHash> clear;
};

/// The OMPL side: a 3D box space whose validity and motion checks are the planner's own.
struct PathPlanner::Ompl {
  class Validity : public ob::StateValidityChecker {
   public:
    Validity(const ob::SpaceInformationPtr& si, Checker& owner) : ob::StateValidityChecker(si), owner_(owner) {}
    bool isValid(const ob::State* s) const override {
      return si_->satisfiesBounds(s) && owner_.isClear(toVec(s));
    }

   private:
    Checker& owner_;
  };

  class Motion : public ob::MotionValidator {
   public:
    Motion(const ob::SpaceInformationPtr& si, Checker& owner) : ob::MotionValidator(si), owner_(owner) {}
    bool checkMotion(const ob::State* s1, const ob::State* s2) const override {
      const bool ok = si_->satisfiesBounds(s2) && owner_.isSegmentClear(toVec(s1), toVec(s2));
      ok ? ++valid_ : ++invalid_;
      return ok;
    }
    bool checkMotion(const ob::State* s1, const ob::State* s2, std::pair<ob::State*, double>& last_valid) const override {
      // Walk in check steps, each an exact capsule test; report the last clear point.
      const Vec3d a = toVec(s1), b = toVec(s2);
      const double length = (b - a).norm();
      const int steps = std::max(1, int(std::ceil(length / owner_.step_m)));
      for (int i = 1; i <= steps; ++i) {
        const double f = double(i) / steps;
        if (!owner_.isSegmentClear(a + (b - a) * (double(i - 1) / steps), a + (b - a) * f)) {
          const double f_ok = double(i - 1) / steps;
          if (last_valid.first) si_->getStateSpace()->interpolate(s1, s2, f_ok, last_valid.first);
          last_valid.second = f_ok;
          ++invalid_;
          return false;
        }
      }
      ++valid_;
      return true;
    }

   private:
    Checker& owner_;
  };

  std::shared_ptr<ob::RealVectorStateSpace> space;
  ob::SpaceInformationPtr si;
  std::uint_fast32_t sampler_seed = 1;

  explicit Ompl(Checker& owner) {
    const Eigen::AlignedBox3d& box = owner.bounds_W;
    space = std::make_shared<ob::RealVectorStateSpace>(3);
    ob::RealVectorBounds bounds(3);
    for (int k = 0; k < 3; ++k) {
      bounds.setLow(k, box.min()[k]);
      bounds.setHigh(k, box.max()[k]);
    }
    space->setBounds(bounds);
    space->setStateSamplerAllocator(
        [this](const ob::StateSpace* s) { return std::make_shared<SeededSampler>(s, sampler_seed); });
    si = std::make_shared<ob::SpaceInformation>(space);
    si->setStateValidityChecker(std::make_shared<Validity>(si, owner));
    si->setMotionValidator(std::make_shared<Motion>(si, owner));
    // OMPL's resolution is a fraction of the space's extent; ours is in metres.
    si->setStateValidityCheckingResolution(std::min(1.0, owner.step_m / space->getMaximumExtent()));
    si->setup();
  }
};

PathPlanner::PathPlanner(const MapQuery& map, const PathConfig& params) : params_(params) {
  params_.validate();
  const double step = params_.check_step_m > 0.0 ? params_.check_step_m : 0.5 * map.voxelSize();
  Eigen::AlignedBox3d bounds = map.worldBox(map.knownBounds());
  if (params_.bounds_W) bounds = bounds.intersection(*params_.bounds_W);
  checker_ = std::make_unique<Checker>(map, params_.clearance_m, step, bounds);
}

PathPlanner::~PathPlanner() = default;
PathPlanner::PathPlanner(PathPlanner&&) noexcept = default;
PathPlanner& PathPlanner::operator=(PathPlanner&&) noexcept = default;

bool PathPlanner::isClear(const Vec3d& p_W) { return checker_->isClear(p_W); }

bool PathPlanner::isSegmentClear(const Vec3d& a_W, const Vec3d& b_W) { return checker_->isSegmentClear(a_W, b_W); }

const Eigen::AlignedBox3d& PathPlanner::searchBounds() const { return checker_->bounds_W; }

PathResult PathPlanner::plan(const Vec3d& start_W, const Vec3d& goal_W, std::uint64_t query_seed) {
  const Stopwatch watch;
  auto finish = [&](PathResult r) {
    r.time_s = watch.s();
    return r;
  };
  PathResult result;
  if (!isClear(start_W)) {
    result.status = PathStatus::StartInvalid;
    return finish(result);
  }
  if (!isClear(goal_W)) {
    result.status = PathStatus::GoalInvalid;
    return finish(result);
  }
  if (isSegmentClear(start_W, goal_W)) {
    result.status = PathStatus::Straight;
    result.waypoints = {start_W, goal_W};
    result.length_m = (goal_W - start_W).norm();
    return finish(result);
  }
  if (params_.search == PathSearch::Grid) return finish(searchGrid(start_W, goal_W));
  PathResult sampled = searchOmpl(start_W, goal_W, splitmix64(params_.seed ^ splitmix64(query_seed)));
  if (sampled.ok() || params_.search != PathSearch::SamplingThenGrid) return finish(sampled);
  PathResult gridded = searchGrid(start_W, goal_W);
  gridded.iterations += sampled.iterations;
  return finish(gridded);
}

PathResult PathPlanner::searchGrid(const Vec3d& start_W, const Vec3d& goal_W) {
  if (!grid_)
    grid_ = std::make_unique<GridSearch>(checker_->probe, params_.clearance_m, checker_->bounds_W, params_.grid);
  const Stopwatch watch;
  const double limit_s = params_.time_limit_s;
  GridSearchResult found = grid_->search(start_W, goal_W, [&watch, limit_s] { return watch.s() > limit_s; });
  PathResult result;
  result.iterations = found.expansions;
  result.status = PathStatus::NoPath;
  if (!found.found) return result;
  // Clear by construction (grid_search.hpp); checked because it is the promise.
  for (std::size_t i = 1; i < found.waypoints.size(); ++i)
    if (!isSegmentClear(found.waypoints[i - 1], found.waypoints[i])) return result;
  result.status = PathStatus::Planned;
  result.waypoints = std::move(found.waypoints);
  result.length_m = polylineLength(result.waypoints);
  return result;
}

PathResult PathPlanner::searchOmpl(const Vec3d& start_W, const Vec3d& goal_W, std::uint64_t seed) {
  initOmpl(params_.seed);
  if (!ompl_) ompl_ = std::make_unique<Ompl>(*checker_);
  ompl_->sampler_seed = std::uint_fast32_t(seed & 0xffffffffu);

  ob::ScopedState<ob::RealVectorStateSpace> start(ompl_->space), goal(ompl_->space);
  for (int k = 0; k < 3; ++k) {
    start[k] = start_W[k];
    goal[k] = goal_W[k];
  }
  auto pdef = std::make_shared<ob::ProblemDefinition>(ompl_->si);
  pdef->setStartAndGoalStates(start, goal);
  auto rrt = std::make_shared<og::RRTConnect>(ompl_->si);
  if (params_.rrt_range_m > 0.0) rrt->setRange(params_.rrt_range_m);
  rrt->setProblemDefinition(pdef);
  rrt->setup();

  PathResult result;
  // RRTConnect evaluates the condition once per iteration; counting the evaluations gives an
  // iteration budget that is the same on every machine.
  const std::uint64_t cap = params_.max_iterations;
  const ob::PlannerTerminationCondition counted([&result, cap] {
    if (cap != 0 && result.iterations >= cap) return true;
    ++result.iterations;
    return false;
  });
  const ob::PlannerStatus status =
      rrt->solve(ob::plannerOrTerminationCondition(counted, ob::timedPlannerTerminationCondition(params_.time_limit_s)));
  if (status != ob::PlannerStatus::EXACT_SOLUTION || !pdef->getSolutionPath()) {
    result.status = PathStatus::NoPath;
    return result;
  }
  auto& path = *pdef->getSolutionPath()->as<og::PathGeometric>();
  auto toPoints = [](const og::PathGeometric& p) {
    std::vector<Vec3d> points;
    for (std::size_t i = 0; i < p.getStateCount(); ++i) {
      const Vec3d v = toVec(p.getState(i));
      if (points.empty() || (v - points.back()).norm() > 1e-9) points.push_back(v);
    }
    return points;
  };
  auto allClear = [this](const std::vector<Vec3d>& points) {
    for (std::size_t i = 1; i < points.size(); ++i)
      if (!isSegmentClear(points[i - 1], points[i])) return false;
    return points.size() >= 2;
  };
  const std::vector<Vec3d> raw = toPoints(path);

  SeededSimplifier simplifier(ompl_->si, std::uint_fast32_t(splitmix64(seed) & 0xffffffffu));
  for (int round = 0; round < params_.simplify_rounds; ++round) {
    const bool reduced = simplifier.reduceVertices(path);
    const bool shortened = simplifier.shortcutPath(path);
    if (!reduced && !shortened) break;
  }
  result.waypoints = toPoints(path);
  // Both searches used the same test, so this holds; it is checked because it is the promise.
  if (!allClear(result.waypoints)) result.waypoints = raw;
  if (!allClear(result.waypoints)) {
    result.waypoints.clear();
    result.status = PathStatus::NoPath;
    return result;
  }
  result.status = PathStatus::Planned;
  result.length_m = polylineLength(result.waypoints);
  return result;
}

}  // namespace vdbmap::planner
