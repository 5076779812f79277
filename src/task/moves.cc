// The arm's other moves: home, a straight retreat up from a tight spot, the gripper alone.
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
// perceived where it was) is left out: going up is the way off it. `exclude`: an object not
// checked at all (the one just let go of, still between the fingers).
CartesianPath straightUp(TrialContext& ctx, double distance, int exclude) {
  PlanningScene s = planningScene(ctx, exclude, true);
  if (ctx.held < 0) s.finger_opening = ctx.gripper_opening;
  auto checker = makeChecker(ctx.options.checker, ctx.robot, s, 0.0);
  for (int k = 0; k < 4 && !checker->isValid(ctx.q_rest); ++k) {
    const std::string hit = checker->lastCollision();
    const std::string obstacle = hit.substr(hit.find(" / ") == std::string::npos ? 0 : hit.find(" / ") + 3);
    if (std::none_of(ctx.objects.begin(), ctx.objects.end(), [&](const ObjectState& x) { return x.name == obstacle; })) break;
    s.ignore.push_back(obstacle);
    checker = makeChecker(ctx.options.checker, ctx.robot, s, 0.0);
  }
  Pose T_up = ctx.robot.fk(ctx.q_rest);
  T_up.translation().z() += distance;
  const CartesianPath up = planCartesianLine(ctx.robot, *checker, ctx.q_rest, T_up, ikNear(ctx), ctx.options.cartesian);
  ctx.out.collision_checks += checker->checks();
  return up;
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
    JointTrajectory leave;
    if (!f.ok() && f.kind == FailureKind::kCollision && f.reason.rfind("start state invalid", 0) == 0) {
      // A start within the padding of an obstacle, or inside an object it pushed (as MoveIt's
      // FixStartStateCollision adapter, which moves the start to a valid state nearby): the hand
      // first leaves straight up, checked as MoveToSafe's, and the planner starts where that ends.
      const CartesianPath up = straightUp(ctx, o.retreat_distance, -1);
      if (up.ok) leave = cartesianTrajectory(ctx.robot, up, ikNear(ctx), o.scaling, o.cartesian, ctx.hw.period());
      if (!leave.empty() && checker->isValid(endOf(leave))) {
        const Failure again = connect(ctx, "plan_home", *checker, s, endOf(leave), ctx.robot.home(), traj);
        if (again.ok()) f = again;
      }
    }
    if (f.ok()) {
      if (!leave.empty()) out.steps.push_back(trajectoryStep("retreat", std::move(leave), ctx.gripper_opening, ctx.held >= 0));
      out.steps.push_back(trajectoryStep("return_home", std::move(traj), ctx.gripper_opening, ctx.held >= 0));
    }
  }
  ctx.out.collision_checks += checker->checks();
  st.compute_seconds = since(t);
  ctx.out.return_home_time += st.compute_seconds;
  return f.ok() ? f : ctx.fail(f);
}

Failure planRetreatUp(TrialContext& ctx, double distance, Plan& out) {
  const TaskOptions& o = ctx.options;
  const auto t = Clock::now();
  StageRecord& st = ctx.stage("plan_safe");
  // The object just let go of stays between the fingers: not checked against them.
  const int just_placed = ctx.out.picks.empty() ? -1 : ctx.out.picks.back().object;
  const CartesianPath up = straightUp(ctx, distance, just_placed);
  Failure f;
  JointTrajectory traj;
  if (!up.ok) f = {"plan_safe", up.kind, up.reason};
  else {
    traj = cartesianTrajectory(ctx.robot, up, ikNear(ctx), o.scaling, o.cartesian, ctx.hw.period());
    if (traj.empty()) f = {"plan_safe", FailureKind::kTimeParameterization, "no smooth time parameterization of the straight line"};
  }
  st.compute_seconds = since(t);
  ctx.out.plan_place_time += st.compute_seconds;
  if (!f.ok()) return ctx.fail(f);
  out = Plan{};
  out.q_start = ctx.q_rest;
  out.name = "safe";
  out.bucket = TimeBucket::kPlace;
  out.q_end = endOf(traj);
  out.steps.push_back(trajectoryStep("retreat", std::move(traj), ctx.gripper_opening, ctx.held >= 0));
  return {};
}

Plan gripperPlan(TrialContext& ctx, double opening, const std::string& stage) {
  Plan p;
  const bool opens = opening > ctx.gripper_opening;
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
