// Pushes: an object no grasp fits (flush against a neighbour or a wall) moved clear by the closed
// fingers, along a face normal towards free room.
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

namespace {

// The footprint of a box on the floor: a rectangle in the xy plane (the box's two axes nearest
// the horizontal, their half extents), for the overlap test of a push's path.
struct Footprint {
  Eigen::Vector2d c, u, v;  // centre, unit axes
  double hu = 0, hv = 0;
};

Footprint footprintOf(const ObjectState& o, const Vec3& shift = Vec3::Zero()) {
  const Mat3 R = o.T_world_object.linear();
  int up = 0;
  for (int a = 1; a < 3; ++a)
    if (std::abs(R.col(a).z()) > std::abs(R.col(up).z())) up = a;
  Footprint f;
  const int a = (up + 1) % 3;
  f.c = (o.T_world_object.translation() + shift).head<2>();
  f.u = R.col(a).head<2>().normalized();
  f.v = Eigen::Vector2d(-f.u.y(), f.u.x());
  // The rectangle bounding the box's shadow: each axis's reach over the three box axes.
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector2d e = R.col(k).head<2>() * o.half_size[k];
    f.hu += std::abs(e.dot(f.u));
    f.hv += std::abs(e.dot(f.v));
  }
  return f;
}

// Whether two rectangles overlap by more than `tolerance` (separating axes).
bool overlap(const Footprint& A, const Footprint& B, double tolerance) {
  for (const Eigen::Vector2d& axis : {A.u, A.v, B.u, B.v}) {
    const double ra = A.hu * std::abs(A.u.dot(axis)) + A.hv * std::abs(A.v.dot(axis));
    const double rb = B.hu * std::abs(B.u.dot(axis)) + B.hv * std::abs(B.v.dot(axis));
    if (std::abs((B.c - A.c).dot(axis)) >= ra + rb - tolerance) return false;
  }
  return true;
}

}  // namespace

namespace {

// A push of `object` (see planPush), or why there is none; records nothing.
Failure planPushOf(TrialContext& ctx, const ObjectState& object, Plan& out) {
  const TaskOptions& o = ctx.options;
  const Mat3 R = object.T_world_object.linear();
  const Vec3 c = object.T_world_object.translation();
  const Pose& T_crop = ctx.perception.T_world_crop;
  const Vec3 crop_half = ctx.perception.crop_half;
  const double floor_z = T_crop.translation().z();
  const double margin = std::min(o.padding, 0.004);  // a push comes within millimetres of objects by design
  // The object's horizontal extent along d (half).
  auto extent = [&](const Vec3& d) { return (R.transpose() * d).cwiseAbs().dot(object.half_size); };
  // Candidate directions: the horizontal projections of the object's face normals, both ways,
  // whose path is free: the object's footprint, moved in 1 cm steps, overlaps no other object
  // (sliding along a touching neighbour is allowed: 2 mm) and stays inside the walls; ranked by
  // the room left around it at the end.
  struct Option {
    double room;
    Vec3 d;
  };
  std::vector<Option> options;
  for (int a = 0; a < 3; ++a)
    for (double sign : {1.0, -1.0}) {
      Vec3 d = sign * R.col(a);
      d.z() = 0;
      if (d.norm() < 0.7) continue;  // a near-vertical axis: no face to push on
      d.normalize();
      // A neighbour in the way is pushed along (singulation), if it has room to go: its own
      // footprint, moved the rest of the push from where it is reached, stays inside the walls and
      // clear of the others.
      bool free = true;
      const int steps = static_cast<int>(std::ceil(o.push_distance / 0.01));
      auto insideWalls = [&](const Footprint& f) {
        const Eigen::Vector2d local = (T_crop.inverse() * Vec3(f.c.x(), f.c.y(), floor_z)).head<2>();
        const double reach = std::max(f.hu, f.hv);
        return std::abs(local.x()) + reach <= crop_half.x() - 0.005 && std::abs(local.y()) + reach <= crop_half.y() - 0.005;
      };
      for (const ObjectState& b : ctx.objects) {
        if (b.index == object.index || picked(ctx, b.index)) continue;
        int first_hit = 0;  // the first step that reaches it: it is shoved the rest of the way
        for (int k = 1; k <= steps && !first_hit; ++k)
          if (overlap(footprintOf(object, (o.push_distance * k / steps) * d), footprintOf(b), 0.002)) first_hit = k;
        if (!first_hit) continue;
        const Footprint shoved = footprintOf(b, (o.push_distance * (steps - first_hit + 1) / steps) * d);
        free = free && insideWalls(shoved);
        for (const ObjectState& e : ctx.objects)
          if (e.index != b.index && e.index != object.index && !picked(ctx, e.index) && overlap(shoved, footprintOf(e), 0.002))
            free = false;
      }
      if (!free) continue;
      const Vec3 to = c + o.push_distance * d;
      const Vec3 local = T_crop.inverse() * to, local_from = T_crop.inverse() * c;
      const double reach = std::max(footprintOf(object).hu, footprintOf(object).hv);
      // Inside the walls with 5 mm to spare along every axis it moves outward on; along one it
      // does not (a cube flush in a corner, moved off one wall along the other), as it was.
      bool inside = true;
      for (int i = 0; i < 2; ++i)
        if (std::abs(local[i]) > std::abs(local_from[i]) + 1e-4 && std::abs(local[i]) + reach > crop_half[i] - 0.005) inside = false;
      if (!inside) continue;
      double room = std::min(crop_half.x() - std::abs(local.x()), crop_half.y() - std::abs(local.y())) - reach;
      for (const ObjectState& b : ctx.objects)
        if (b.index != object.index && !picked(ctx, b.index))
          room = std::min(room, (b.T_world_object.translation() - to).head<2>().norm() - 0.06);
      options.push_back({room, d});
    }
  std::stable_sort(options.begin(), options.end(), [](const Option& x, const Option& y) { return x.room > y.room; });
  Failure last{"plan_push", FailureKind::kNoGrasp, "no push direction with room for " + object.name};
  PlanningScene with_target = planningScene(ctx, -1, false), without = planningScene(ctx, object.index, false);
  with_target.finger_opening = without.finger_opening = 0.0;
  auto full = makeChecker(o.checker, ctx.robot, with_target, margin);
  auto pushing = makeChecker(o.checker, ctx.robot, without, margin);
  auto connecting = makeChecker(o.checker, ctx.robot, with_target, o.padding);
  const double preferred_yaw = yawOf(ctx.robot.fk(ctx.robot.home()).linear());
  for (const Option& option : options) {
    const Vec3& d = option.d;
    // The closed fingers' flat side (the TCP's x axis along the push), low on the object.
    double yaw = std::atan2(d.y(), d.x());
    if (std::abs(wrapAngle(yaw + M_PI - preferred_yaw)) < std::abs(wrapAngle(yaw - preferred_yaw))) yaw = wrapAngle(yaw + M_PI);
    const Mat3 Rt = topDownRotation(yaw);
    // 2 cm behind the face: a closed finger's half thickness and a gap (the Panda's fingers are
    // 2.1 cm thick); the checkers prove the fingers clear of the face and the floor.
    // Low on the face: the TCP 5 mm below the object's centre, so the pads' contact (from about
    // 4 mm below the TCP upwards) is near the centre's height. Pushed high, a cube tips onto its far
    // edge and the pads' friction wedges it against the floor.
    Vec3 p0 = c - (extent(d) + 0.02) * d;
    p0.z() = std::max(floor_z + 0.02, c.z() - 0.005);
    Pose T0 = makePose(p0, Rt), T1 = makePose(p0 + o.push_distance * d, Rt);
    Pose T_pre = T0, T_up = T1;
    T_pre.translation().z() += o.approach_distance;
    T_up.translation().z() += o.retreat_distance;
    IkResult pre = ikFar(ctx, T_pre, ctx.robot.home());
    if (!pre.ok()) {
      last = {"plan_push", FailureKind::kIk, "pre-push: " + pre.reason};
      continue;
    }
    if (!connecting->isValid(pre.q())) {
      last = {"plan_push", FailureKind::kCollision, "pre-push configuration in collision (" + connecting->lastCollision() + ")"};
      continue;
    }
    CartesianPath down = planCartesianLine(ctx.robot, *full, pre.q(), T0, ikNear(ctx), o.cartesian);
    bool drag = false;
    if (!down.ok && o.drag_depth > 0) {
      // No room for the fingers beside it: drag it by its top instead. The closed fingertips
      // (their flat side along d, within the top face: 2.1 x 3.6 cm on a 5 cm face) come down on
      // the upper face a little behind its centre, press drag_depth into it and slide it along d
      // by friction (the pads' 1.5 against a bin floor's lower friction; it slides rather than tips
      // while the floor's friction stays under the face's half width over its height).
      last = {"plan_push", down.kind, "down beside the object: " + down.reason};
      const double top = c.z() + (R.transpose() * Vec3::UnitZ()).cwiseAbs().dot(object.half_size);
      const double tip_below_tcp = ctx.robot.fingertipBelowTcp();
      Vec3 q0 = c - 0.01 * d;
      q0.z() = top - o.drag_depth + tip_below_tcp;
      T0 = makePose(q0, Rt);
      T1 = makePose(q0 + o.push_distance * d, Rt);
      T_pre = T0;
      T_pre.translation().z() += o.approach_distance;
      T_up = T1;
      T_up.translation().z() += o.retreat_distance;
      pre = ikFar(ctx, T_pre, ctx.robot.home());
      if (!pre.ok() || !connecting->isValid(pre.q())) continue;
      down = planCartesianLine(ctx.robot, *pushing, pre.q(), T0, ikNear(ctx), o.cartesian);
      if (!down.ok) {
        last = {"plan_push", down.kind, "down onto the object's top (drag): " + down.reason};
        continue;
      }
      drag = true;
    }
    if (!down.ok) {
      last = {"plan_push", down.kind, "down beside the object: " + down.reason};
      continue;
    }
    const CartesianPath push = planCartesianLine(ctx.robot, *pushing, down.waypoints.back(), T1, ikNear(ctx), o.cartesian);
    if (!push.ok) {
      last = {"plan_push", push.kind, "push: " + push.reason};
      continue;
    }
    const CartesianPath up = planCartesianLine(ctx.robot, *pushing, push.waypoints.back(), T_up, ikNear(ctx), o.cartesian);
    if (!up.ok) {
      last = {"plan_push", up.kind, "up after the push: " + up.reason};
      continue;
    }
    JointTrajectory t_connect;
    const Failure f = connect(ctx, "plan_push", *connecting, with_target, ctx.q_rest, pre.q(), t_connect);
    if (!f.ok()) {
      last = f;
      continue;
    }
    const double dt = ctx.hw.period();
    // Each line starts where the one before ends. The contact moves (down beside or onto the
    // object, the push or drag) go no faster than 0.2 m/s and 1 m/s^2, however fast the cell's
    // free lines: a push is a contact task (at 0.5 m/s it struck the cube with over 100 N).
    CartesianOptions contact = o.cartesian;
    contact.speed = std::min(contact.speed, 0.2);
    contact.acceleration = std::min(contact.acceleration, 1.0);
    JointTrajectory t_down = cartesianTrajectory(ctx.robot, down, ikNear(ctx), o.scaling, contact, dt), t_push, t_up;
    if (!t_down.empty()) {
      const VecX q_down = endOf(t_down);
      t_push = cartesianTrajectory(ctx.robot, push, ikNear(ctx), o.scaling, contact, dt, &q_down);
    }
    if (!t_push.empty()) {
      const VecX q_pushed = endOf(t_push);
      t_up = cartesianTrajectory(ctx.robot, up, ikNear(ctx), o.scaling, o.cartesian, dt, &q_pushed);
    }
    if (t_down.empty() || t_push.empty() || t_up.empty()) {
      last = {"plan_push", FailureKind::kTimeParameterization, "no smooth time parameterization of a straight line"};
      continue;
    }
    ctx.out.collision_checks += full->checks() + pushing->checks() + connecting->checks();
    out = Plan{};
    out.q_start = ctx.q_rest;
    out.name = "push";
    out.object = object.index;
    out.bucket = TimeBucket::kPick;
    out.steps.push_back(gripperStep("push_close_gripper", ctx.q_rest, 0.0));
    out.steps.push_back(trajectoryStep("move_prepush", std::move(t_connect), 0.0, false));
    out.steps.push_back(trajectoryStep(drag ? "drag_down" : "push_down", std::move(t_down), 0.0, false));
    out.steps.back().stiff = drag;  // the fingertips end pressing on the top: held firmly there
    out.steps.push_back(trajectoryStep(drag ? "drag" : "push", std::move(t_push), 0.0, false));
    out.steps.back().stiff = true;
    out.q_end = endOf(t_up);
    out.steps.push_back(trajectoryStep("push_up", std::move(t_up), 0.0, false));
    return {};
  }
  ctx.out.collision_checks += full->checks() + pushing->checks() + connecting->checks();
  return last;
}

}  // namespace

Failure planPush(TrialContext& ctx, const ObjectState& object, Plan& out) {
  const auto t = Clock::now();
  StageRecord& st = ctx.stage("plan_push");
  // The object named first; when it has no push, the others by room (making room anywhere in a
  // cluster helps).
  std::vector<const ObjectState*> order{&object};
  for (int i : objectsByRoom(ctx))
    if (ctx.objects[i].index != object.index) order.push_back(&ctx.objects[i]);
  Failure first;
  bool found = false;
  for (const ObjectState* o : order) {
    const Failure f = planPushOf(ctx, *o, out);
    found = f.ok();
    if (found) break;
    if (o == &object) first = f;
    ctx.why_not[o->index] = "no grasp fits, and no push: " + f.reason;
  }
  st.compute_seconds = since(t);
  ctx.out.plan_pick_time += st.compute_seconds;
  if (!found) return ctx.fail(first);
  ++ctx.out.pushes;
  return {};
}

}  // namespace mm
