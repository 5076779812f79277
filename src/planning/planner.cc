#include "planning/planner.h"

#include <ompl/base/SpaceInformation.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/base/objectives/PathLengthOptimizationObjective.h>
#include <ompl/geometric/planners/informedtrees/ABITstar.h>
#include <ompl/geometric/planners/informedtrees/AITstar.h>
#include <ompl/geometric/planners/informedtrees/BITstar.h>
#include <ompl/geometric/planners/kpiece/KPIECE1.h>
#include <ompl/geometric/planners/prm/LazyPRMstar.h>
#include <ompl/geometric/planners/prm/PRMstar.h>
#include <ompl/geometric/planners/rrt/InformedRRTstar.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/geometric/planners/rrt/RRTstar.h>
#include <ompl/config.h>
#include <ompl/util/Console.h>

#include <chrono>
#include <limits>
#include <mutex>

#include "core/rng.h"

namespace mm {
namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace {

// OMPL's instance RNGs draw their seeds from one global generator in creation order, which would
// tie results to thread scheduling; these subclasses seed each instance from our stream instead.
class SeededSampler : public ob::RealVectorStateSampler {
 public:
  SeededSampler(const ob::StateSpace* space, uint32_t seed) : ob::RealVectorStateSampler(space) {
    rng_.setLocalSeed(seed);
  }
};
class SeededRRTConnect : public og::RRTConnect {
 public:
  SeededRRTConnect(const ob::SpaceInformationPtr& si, uint32_t seed) : og::RRTConnect(si) { rng_.setLocalSeed(seed); }
};
class SeededSimplifier : public og::PathSimplifier {
 public:
  SeededSimplifier(const ob::SpaceInformationPtr& si, uint32_t seed) : og::PathSimplifier(si) { rng_.setLocalSeed(seed); }
};

// Planners by name. RRTConnect is seeded locally (the campaign plans in parallel threads); the
// others draw on OMPL's global seed generator, deterministic in a single-threaded process.
ob::PlannerPtr makePlanner(const std::string& name, const ob::SpaceInformationPtr& si, uint32_t seed) {
  if (name == "RRTConnect") return std::make_shared<SeededRRTConnect>(si, seed);
  if (name == "RRTstar") return std::make_shared<og::RRTstar>(si);
  if (name == "InformedRRTstar") return std::make_shared<og::InformedRRTstar>(si);
  if (name == "BITstar") return std::make_shared<og::BITstar>(si);
  if (name == "ABITstar") return std::make_shared<og::ABITstar>(si);
  if (name == "AITstar") return std::make_shared<og::AITstar>(si);
  if (name == "PRMstar") return std::make_shared<og::PRMstar>(si);
  if (name == "LazyPRMstar") return std::make_shared<og::LazyPRMstar>(si);
  if (name == "KPIECE1") return std::make_shared<og::KPIECE1>(si);
  return nullptr;
}

double seconds(std::chrono::steady_clock::time_point a) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
}

}  // namespace

// Debian's OMPL 1.5.2 defines OMPL_VERSION as "", so build it from the numeric parts.
void PlannerOptions::declare(ConfigArchive& a) {
  a.choice("planner", planner, plannerNames(),
           "OMPL planner (optimizing ones stop at their first solution; planners other than RRTConnect repeat exactly only with jobs: 1)");
  a.value("time_limit", time_limit, {0.01, 600.0}, "s", "wall-clock cap per planning call (reaching it is recorded)");
  a.value("simplify", simplify, "shortcut and reduce the planned path");
  a.value("resolution", resolution, {0.001, 0.2}, "rad", "edge validation step");
  a.value("test_slowdown", test_slowdown, {1, 1000}, "",
          "test only: the planner checks each state this many times (a deliberately slowed planner: the same paths, more "
          "collision checks and wall time; the gate's test)");
  a.value("test_time_factor", test_time_factor, {1, 1000}, "",
          "test only: each planning call takes this many times its wall time (busy-waiting the rest): a planner that many "
          "times slower, with the same paths and counters (the side-by-side timing gate's test)");
}

std::vector<std::string> plannerNames() {
  return {"RRTConnect", "RRTstar", "InformedRRTstar", "BITstar", "ABITstar", "AITstar", "PRMstar", "LazyPRMstar", "KPIECE1"};
}

void seedOmplGlobally(uint32_t seed) {
  static std::once_flag once;
  std::call_once(once, [seed] { ompl::RNG::setSeed(seed); });
}

std::string omplVersion() {
  return std::to_string(OMPL_MAJOR_VERSION) + "." + std::to_string(OMPL_MINOR_VERSION) + "." + std::to_string(OMPL_PATCH_VERSION);
}

bool segmentValid(CollisionChecker& checker, const VecX& a, const VecX& b, double resolution) {
  const double len = (b - a).norm();
  const int n = std::max(1, static_cast<int>(std::ceil(len / resolution)));
  for (int i = 1; i <= n; ++i)
    if (!checker.isValid(a + (b - a) * (static_cast<double>(i) / n))) return false;
  return true;
}

PlanResult planJointPath(const RobotModel& robot, CollisionChecker& checker, const VecX& start, const VecX& goal,
                         uint64_t seed, const PlannerOptions& o) {
  static std::once_flag quiet;
  std::call_once(quiet, [] { ompl::msg::setLogLevel(ompl::msg::LOG_ERROR); });
  // test_time_factor: the call's wall time stretched to that many times, on every way out.
  struct Stretch {
    double factor;
    std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
    ~Stretch() {
      if (factor <= 1) return;
      const auto until = t0 + (std::chrono::steady_clock::now() - t0) * factor;
      while (std::chrono::steady_clock::now() < until) {
      }
    }
  } stretch{o.test_time_factor};
  PlanResult r;
  const long checks0 = checker.checks();
  if (!checker.isValid(start)) {
    r.kind = FailureKind::kCollision;
    r.reason = "start state invalid (" + checker.lastCollision() + ")";
    return r;
  }
  if (!checker.isValid(goal)) {
    r.kind = FailureKind::kCollision;
    r.reason = "goal state invalid (" + checker.lastCollision() + ")";
    return r;
  }
  const int n = robot.dof();
  auto space = std::make_shared<ob::RealVectorStateSpace>(n);
  ob::RealVectorBounds bounds(n);
  for (int i = 0; i < n; ++i) bounds.setLow(i, robot.lower()[i]), bounds.setHigh(i, robot.upper()[i]);
  space->setBounds(bounds);
  Rng rng(seed);
  const uint32_t sampler_seed = rng.seed32();
  space->setStateSamplerAllocator([sampler_seed, k = 0u](const ob::StateSpace* s) mutable {
    return std::make_shared<SeededSampler>(s, sampler_seed + 7919u * k++);
  });
  auto si = std::make_shared<ob::SpaceInformation>(space);
  VecX qs(n);
  si->setStateValidityChecker([&](const ob::State* st) {
    const double* v = st->as<ob::RealVectorStateSpace::StateType>()->values;
    for (int i = 0; i < n; ++i) qs[i] = v[i];
    for (int k = 1; k < o.test_slowdown; ++k) checker.isValid(qs);
    return checker.isValid(qs);
  });
  si->setStateValidityCheckingResolution(o.resolution / space->getMaximumExtent());
  si->setup();
  auto pdef = std::make_shared<ob::ProblemDefinition>(si);
  ob::ScopedState<> s(space), g(space);
  for (int i = 0; i < n; ++i) s[i] = start[i], g[i] = goal[i];
  pdef->setStartAndGoalStates(s, g);
  // Optimizing planners stop at their first solution: every planner is timed to a feasible path.
  auto objective = std::make_shared<ob::PathLengthOptimizationObjective>(si);
  objective->setCostThreshold(ob::Cost(std::numeric_limits<double>::infinity()));
  pdef->setOptimizationObjective(objective);
  auto planner = makePlanner(o.planner, si, rng.seed32());
  if (!planner) {
    r.kind = FailureKind::kPlanning;
    r.reason = "unknown planner '" + o.planner + "'";
    return r;
  }
  planner->setProblemDefinition(pdef);
  planner->setup();
  // Frees the planner's graph before it is destroyed: OMPL 1.5.2's LazyPRM leaks the start and goal
  // milestones its destructor leaves (ompl/ompl#833; clear() frees them; found by LeakSanitizer).
  struct ClearOnExit {
    ob::PlannerPtr p;
    ~ClearOnExit() { p->clear(); }
  } clear_on_exit{planner};
  const auto t0 = std::chrono::steady_clock::now();
  const ob::PlannerTerminationCondition budget = ob::timedPlannerTerminationCondition(o.time_limit);
  const ob::PlannerStatus status = planner->solve(budget);
  r.plan_seconds = seconds(t0);
  if (status != ob::PlannerStatus::EXACT_SOLUTION) {
    // The budget's own clock says whether it ran out (OMPL times it on the system clock, and a
    // planner that ends with an approximate solution does not say TIMEOUT; our steady clock's
    // plan_seconds may fall a hair short of the limit).
    r.hit_time_limit = status == ob::PlannerStatus::TIMEOUT || budget();
    r.kind = FailureKind::kPlanning;
    r.reason = std::string("planner ") + o.planner + ": " + status.asString();
    r.collision_checks = checker.checks() - checks0;
    return r;
  }
  auto& path = static_cast<og::PathGeometric&>(*pdef->getSolutionPath());
  r.raw_length = path.length();
  r.raw_waypoints = static_cast<int>(path.getStateCount());
  if (o.simplify) {
    const auto t1 = std::chrono::steady_clock::now();
    SeededSimplifier simp(si, rng.seed32());
    simp.reduceVertices(path);
    simp.shortcutPath(path, o.simplify_steps);
    simp.reduceVertices(path);
    simp.collapseCloseVertices(path);
    r.simplify_seconds = seconds(t1);
  }
  for (size_t k = 0; k < path.getStateCount(); ++k) {
    const double* v = path.getState(k)->as<ob::RealVectorStateSpace::StateType>()->values;
    r.path.push_back(Eigen::Map<const VecX>(v, n));
  }
  r.path.front() = start;  // exact end points (OMPL copies them, this guards rounding)
  r.path.back() = goal;
  for (size_t k = 1; k < r.path.size(); ++k) r.length += (r.path[k] - r.path[k - 1]).norm();
  // Every edge must hold at our resolution, whatever the simplifier did.
  for (size_t k = 1; k < r.path.size(); ++k)
    if (!segmentValid(checker, r.path[k - 1], r.path[k], o.resolution)) {
      r.path.clear();
      r.kind = FailureKind::kPlanning;
      r.reason = "simplified path failed re-validation (" + checker.lastCollision() + ")";
      r.collision_checks = checker.checks() - checks0;
      return r;
    }
  r.ok = true;
  r.collision_checks = checker.checks() - checks0;
  return r;
}

}  // namespace mm
