// The arm's other moves: home, a retreat up from a tight spot (out of a static part first, if the
// hand is inside one), the gripper alone.
#include "task/pick_place.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/error.h"
#include "planning/blend.h"
#include "planning/chomp.h"
#include "planning/time_parameterization.h"
#include "sim/hardware.h"
#include "task/plan_steps.h"

namespace mm {

// ---- home, retreat, gripper ------------------------------------------------------------------

namespace {

// The straight line `distance` up from where the arm rests. Unpadded: backing out straight up is
// how the hand leaves a spot where it touches (a missed grasp among the walls), which the padded
// planner would call a collision from the start. An object the hand starts inside (one it pushed,
// perceived where it was, or one it set down) is left out: going up is the way off it. `exclude`:
// an object not checked at all (the one just let go of, still between the fingers).
//
// A hand that starts inside a static part of the cell (a protective stop that left a finger in a
// bin's wall) cannot go up through it, nor can the cell be ignored. As MoveIt's
// FixStartStateCollision adapter moves an invalid start to a valid state nearby, the hand first
// slides out sideways, horizontally, the way that leaves the part soonest (16 ways), then rises.
// Deterministic (a fixed order of tries, no draws). The lines to run, in order; the last one's
// `ok` and reason are the outcome.
std::vector<CartesianPath> wayUp(TrialContext& ctx, double distance, int exclude) {
  PlanningScene s = planningScene(ctx, exclude, true);
  if (ctx.held < 0) s.finger_opening = ctx.gripper_opening;
  auto checker = makeChecker(ctx.options.checker, ctx.robot, s, 0.0);
  const auto obstacleOf = [](const std::string& hit) {
    const auto at = hit.find(" / ");
    return hit.substr(at == std::string::npos ? 0 : at + 3);
  };
  // Objects the hand starts inside are left out; so is a static part of the cell (the first met)
  // while looking for them, and then checked again: its way out is looked for below.
  std::string inside;  // the static part the hand starts inside, if any
  for (int k = 0; k < 4 && !checker->isValid(ctx.q_rest); ++k) {
    const std::string obstacle = obstacleOf(checker->lastCollision());
    // A perceived object, or one let go of at its target (planningScene's "placed_<k>": the hand
    // that set it down may still be about it).
    const bool object = std::any_of(ctx.objects.begin(), ctx.objects.end(), [&](const ObjectState& x) { return x.name == obstacle; }) ||
                        std::any_of(ctx.out.picks.begin(), ctx.out.picks.end(),
                                    [&](const PickRecord& p) { return p.at_target && obstacle == "placed_" + std::to_string(p.object); });
    const bool part = !object && inside.empty() &&
                      std::any_of(ctx.statics.begin(), ctx.statics.end(), [&](const Obstacle& x) { return x.name == obstacle; });
    if (!object && !part) break;
    if (part) inside = obstacle;
    s.ignore.push_back(obstacle);
    checker = makeChecker(ctx.options.checker, ctx.robot, s, 0.0);
  }
  if (!inside.empty()) {
    s.ignore.erase(std::find(s.ignore.begin(), s.ignore.end(), inside));
    checker = makeChecker(ctx.options.checker, ctx.robot, s, 0.0);
  }
  const Pose T0 = ctx.robot.fk(ctx.q_rest);
  const auto lineUp = [&](const VecX& q_from, const Pose& T_from) {
    Pose T_up = T_from;
    T_up.translation().z() += distance;
    return planCartesianLine(ctx.robot, *checker, q_from, T_up, ikNear(ctx), ctx.options.cartesian);
  };
  CartesianPath up = lineUp(ctx.q_rest, T0);
  if (!up.ok && !inside.empty()) {
    // How far the hand must move each way to be clear of that part alone: the shortest is the way
    // out, through the part's nearest face (a way through a thin wall is longer by its thickness).
    // The line then goes on 5-15 mm past it, checked against everything else, and must end free.
    constexpr int kWays = 16;
    constexpr double kStep = 0.001, kFarthest = 0.04;
    const auto way = [](int k) { return Vec3(std::cos(2 * M_PI * k / kWays), std::sin(2 * M_PI * k / kWays), 0.0); };
    PlanningScene alone = s, loose = s;
    alone.obstacles.clear();
    for (const Obstacle& x : s.obstacles)
      if (x.name == inside) alone.obstacles.push_back(x);
    loose.ignore.push_back(inside);
    auto part = makeChecker(ctx.options.checker, ctx.robot, alone, 0.0);
    auto beside = makeChecker(ctx.options.checker, ctx.robot, loose, 0.0);
    std::vector<std::pair<double, int>> exits;  // (distance, way)
    for (int k = 0; k < kWays; ++k) {
      VecX q = ctx.q_rest, next;
      for (int i = 1; i * kStep <= kFarthest + 1e-9; ++i) {
        Pose T = T0;
        T.translation() += i * kStep * way(k);
        if (!ikNear(ctx)(T, q, next)) break;
        q = next;
        if (part->isValid(q)) {
          exits.emplace_back(i * kStep, k);
          break;
        }
      }
    }
    // Only ways out of the part's side nearest the TCP (a box's side face whose plane it is least
    // far inside or nearest outside of; a round part's side towards it): the finger in the part
    // is on the TCP's side of it, and a way through a thin wall may be as short in the checker's
    // shapes. The shortest first.
    const Obstacle& what = *std::find_if(ctx.statics.begin(), ctx.statics.end(), [&](const Obstacle& x) { return x.name == inside; });
    const Vec3 local = what.T_world.inverse() * T0.translation();
    Vec3 outward = what.T_world.translation();
    outward = T0.translation() - outward;
    if (what.type == Obstacle::Type::kBox) {
      int a = -1;
      for (int i = 0; i < 3; ++i) {
        const Vec3 axis = what.T_world.linear().col(i);
        if (std::abs(axis.z()) > 0.7) continue;  // a top or bottom face
        if (a < 0 || std::abs(local[i]) - what.size[i] > std::abs(local[a]) - what.size[a]) a = i;
      }
      if (a >= 0) outward = (local[a] < 0 ? -1.0 : 1.0) * what.T_world.linear().col(a);
    }
    outward.z() = 0;
    if (outward.norm() > 1e-9) outward.normalize();
    exits.erase(std::remove_if(exits.begin(), exits.end(), [&](const auto& e) { return way(e.second).dot(outward) < 0.3; }), exits.end());
    std::sort(exits.begin(), exits.end());
    for (const auto& [d, k] : exits) {
      for (const double margin : {0.005, 0.01, 0.015}) {
        Pose T = T0;
        T.translation() += (d + margin) * way(k);
        const CartesianPath side = planCartesianLine(ctx.robot, *beside, ctx.q_rest, T, ikNear(ctx), ctx.options.cartesian);
        if (!side.ok || !checker->isValid(side.waypoints.back())) continue;
        // Once out of the part, the line stays out of it.
        bool stays_out = true;
        for (size_t i = 1; i < side.waypoints.size() && stays_out; ++i)
          if (static_cast<double>(i) / static_cast<double>(side.waypoints.size() - 1) * (d + margin) >= d)
            stays_out = part->isValid(side.waypoints[i]);
        if (!stays_out) continue;
        CartesianPath then = lineUp(side.waypoints.back(), T);
        if (!then.ok) continue;
        ctx.out.collision_checks += checker->checks() + part->checks() + beside->checks();
        return {side, then};
      }
    }
    ctx.out.collision_checks += part->checks() + beside->checks();
    up.reason += "; no way out of " + inside + " sideways";
  }
  ctx.out.collision_checks += checker->checks();
  return {up};
}

// The lines' trajectories, one after the other; empty when one has no smooth timing.
std::vector<JointTrajectory> trajectoriesOf(TrialContext& ctx, const std::vector<CartesianPath>& lines) {
  std::vector<JointTrajectory> out;
  for (const CartesianPath& line : lines) {
    const VecX from = out.empty() ? line.waypoints.front() : endOf(out.back());
    out.push_back(cartesianTrajectory(ctx.robot, line, ikNear(ctx), ctx.options.scaling, ctx.options.cartesian,
                                      ctx.hw.period(), &from));
    if (out.back().empty()) return {};
  }
  return out;
}

}  // namespace

Failure planHome(TrialContext& ctx, Plan& out) {
  const TaskOptions& o = ctx.options;
  const auto t = Clock::now();
  StageRecord& st = ctx.stage("plan_home");
  PlanningScene s = planningScene(ctx, -1, true);
  if (ctx.held < 0) s.finger_opening = ctx.gripper_opening;
  auto checker = makeChecker(o.checker, ctx.robot, s, o.padding);
  out = Plan{};
  out.q_start = ctx.q_rest;
  out.name = "home";
  out.bucket = TimeBucket::kHome;
  out.q_end = ctx.robot.home();
  Failure f;
  if ((ctx.q_rest - ctx.robot.home()).cwiseAbs().maxCoeff() > 1e-9) {
    JointTrajectory traj;
    f = connect(ctx, "plan_home", *checker, s, ctx.q_rest, ctx.robot.home(), traj);
    std::vector<JointTrajectory> leave;
    if (!f.ok() && f.kind == FailureKind::kCollision && f.reason.rfind("start state invalid", 0) == 0) {
      // A start within the padding of an obstacle, or inside an object it pushed (as MoveIt's
      // FixStartStateCollision adapter, which moves the start to a valid state nearby): the hand
      // first leaves straight up, checked as MoveToSafe's (out of a static part first, if it is
      // inside one), and the planner starts where that ends.
      const std::vector<CartesianPath> up = wayUp(ctx, o.retreat_distance, -1);
      if (up.back().ok) leave = trajectoriesOf(ctx, up);
      if (!leave.empty() && checker->isValid(endOf(leave.back()))) {
        const Failure again = connect(ctx, "plan_home", *checker, s, endOf(leave.back()), ctx.robot.home(), traj);
        if (again.ok()) f = again;
      }
    }
    if (f.ok()) {
      for (JointTrajectory& line : leave)
        out.steps.push_back(trajectoryStep("retreat", std::move(line), ctx.gripper_opening, ctx.held >= 0));
      out.steps.push_back(trajectoryStep("return_home", std::move(traj), ctx.gripper_opening, ctx.held >= 0));
    }
  }
  ctx.out.collision_checks += checker->checks();
  st.compute_seconds = since(t);
  ctx.out.return_home_time += st.compute_seconds;
  return f.ok() ? f : ctx.fail(f);
}

Failure planRetreatUp(TrialContext& ctx, double distance, Plan& out) {
  const auto t = Clock::now();
  StageRecord& st = ctx.stage("plan_safe");
  // The object just let go of stays between the fingers: not checked against them.
  const int just_placed = ctx.out.picks.empty() ? -1 : ctx.out.picks.back().object;
  const std::vector<CartesianPath> up = wayUp(ctx, distance, just_placed);
  Failure f;
  std::vector<JointTrajectory> trajs;
  if (!up.back().ok) f = {"plan_safe", up.back().kind, up.back().reason};
  else {
    trajs = trajectoriesOf(ctx, up);
    if (trajs.empty()) f = {"plan_safe", FailureKind::kTimeParameterization, "no smooth time parameterization of the straight line"};
  }
  st.compute_seconds = since(t);
  ctx.out.plan_place_time += st.compute_seconds;
  if (!f.ok()) return ctx.fail(f);
  out = Plan{};
  out.q_start = ctx.q_rest;
  out.name = "safe";
  out.bucket = TimeBucket::kPlace;
  out.q_end = endOf(trajs.back());
  for (JointTrajectory& line : trajs)
    out.steps.push_back(trajectoryStep("retreat", std::move(line), ctx.gripper_opening, ctx.held >= 0));
  return {};
}

namespace {

// How far the fingers may open where the arm rests: to `opening`, or, where fingers that open
// would come within 3 mm of a part of the cell (a bin's wall beside a hand that stopped on its way
// up after a missed grasp), the widest opening that keeps them that far from every part, found by
// halving to a quarter of a millimetre, and never less than they are open now (a hand already
// that near a part stays as it is). Only the cell's parts are checked: what is between or beside
// the fingers is what opening lets go of. A real gripper opening against a wall stalls on it; the
// simulator's pushes on into it, a collision (seed 3's packed round 116, with the cut at a waist).
double roomToOpen(TrialContext& ctx, double opening) {
  constexpr double kRoom = 0.003;  // [m] the fingers' clearance from the parts: the arm held at a stop gives a little
  PlanningScene s;
  s.obstacles = ctx.statics;
  long checks = 0;
  auto fits = [&](double w) {
    s.finger_opening = w;
    auto checker = makeChecker(ctx.options.checker, ctx.robot, s, kRoom);
    const bool valid = checker->isValid(ctx.q_rest);
    checks += checker->checks();
    return valid;
  };
  double lo = ctx.gripper_opening, hi = opening;
  if (!fits(hi)) {
    if (fits(lo))
      while (hi - lo > 2.5e-4) {
        const double mid = (lo + hi) / 2;
        (fits(mid) ? lo : hi) = mid;
      }
    opening = lo;
  }
  ctx.out.collision_checks += checks;
  return opening;
}

}  // namespace

Plan gripperPlan(TrialContext& ctx, double opening, const std::string& stage) {
  Plan p;
  const bool opens = opening > ctx.gripper_opening;
  if (opens) opening = roomToOpen(ctx, opening);
  p.q_start = ctx.q_rest;
  p.name = "gripper";
  p.bucket = ctx.held >= 0 ? TimeBucket::kPlace : TimeBucket::kPick;
  PlanStep s = gripperStep(stage, ctx.q_rest, opening);
  s.release = opens && ctx.held >= 0;
  s.take_hold = opening < ctx.gripper_opening;
  p.steps.push_back(s);
  p.q_end = ctx.q_rest;
  return p;
}

}  // namespace mm
