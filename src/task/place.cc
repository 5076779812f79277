// The place: the held object set down to rest at its target (connect to the pre-place, lower;
// open, detach and retreat when it is let go of).
#include "task/pick_place.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "planning/blend.h"
#include "planning/chomp.h"
#include "planning/time_parameterization.h"
#include "sim/hardware.h"
#include "task/plan_steps.h"

namespace mm {

namespace {
// place.any_yaw's turns about the vertical, in 30 degree steps, the least first.
constexpr int kTurns[] = {1, -1, 2, -2, 3, -3, 4, -4, 5, -5, 6};
}  // namespace

// ---- place -----------------------------------------------------------------------------------

Failure planPlace(TrialContext& ctx, const Pose& T_world_object, bool release, Plan& out) {
  const TaskOptions& o = ctx.options;
  const double travel = ctx.robot.spec().gripper.travel;
  const auto t = Clock::now();
  StageRecord* st = &ctx.stage("place_pose_ik");
  auto done = [&](const Failure& f) {
    st->compute_seconds = since(t);
    ctx.out.plan_place_time += st->compute_seconds;
    return f.ok() ? f : ctx.fail(f);
  };
  if (ctx.held < 0) return done({"place_pose_ik", FailureKind::kPrecondition, "nothing in the hand to place"});
  const VecX q_lift = ctx.q_rest;
  const Vec3 half = ctx.held_record.half_size;
  const PlanningScene carrying_scene = planningScene(ctx, -1, true);
  auto carrying = makeChecker(o.checker, ctx.robot, carrying_scene, o.padding);
  // Placing: the held object goes down to the tray with no padding of its own. A grasp from the
  // camera's points was cleared against the bin's floor with cloud_padding (its fingertips may
  // reach within millimetres of the object's bottom): set down, the same fingers come as near the
  // tray's floor, so the descent is checked with that padding too (the whole arm's, against the
  // objects already in the tray as well), and the retreat from it when the planner's fails.
  const double down_padding = ctx.held_record.grasp_type == graspTypeName(GraspType::kCloud) ||
                                      ctx.held_record.grasp_type == graspTypeName(GraspType::kExternal)
                                  ? o.cloudGraspPadding()
                                  : o.padding;
  PlanningScene ps = planningScene(ctx, -1, true);
  ps.attached_padding = -kSupportTolerance;
  auto descending = wallPaddedChecker(ctx, ps, down_padding);
  // TCP poses that put the object at the target, one per symmetry of the box (a cube held on its
  // side is placed on that side) that keeps the hand within 45 deg of pointing down; least wrist
  // turn and tilt first.
  // The target rests the object on the place surface: its centre the held object's own half
  // height above it.
  Pose T_target = T_world_object;
  if (ctx.target_half_height >= 0) T_target.translation().z() += half.z() - ctx.target_half_height;
  if (ctx.held_shape == ObjectShape::kMesh) {
    // A solid with no symmetry declared is set down on the face it rested on when picked (turning
    // it over needs a regrasp), at the target's yaw: the target is that orientation.
    // The turn about the vertical that brings its most horizontal axis onto the target's same axis
    // (yawOf would read the x axis, which may stand upright when it lies on its side).
    const Mat3 R_held = (ctx.robot.fk(q_lift) * ctx.T_tcp_held).linear();
    const Mat3 R_goal = T_target.linear();
    int a = 0;
    for (int k = 1; k < 3; ++k)
      if (std::abs(R_held(2, k)) < std::abs(R_held(2, a))) a = k;
    const double turn = std::atan2(R_goal(1, a), R_goal(0, a)) - std::atan2(R_held(1, a), R_held(0, a));
    T_target.linear() = rotZ(turn) * R_held;
    if (ctx.held_pieces && ctx.target_half_height >= 0) {  // its lowest point on the surface, not its box's
      double low = INFINITY;
      for (const ConvexPiece& piece : *ctx.held_pieces)
        for (const Vec3& v : piece.vertices) low = std::min(low, (T_target.linear() * v).z());
      T_target.translation().z() += -low - half.z();
    }
  }
  Pose T_obj_place = T_target;
  T_obj_place.translation().z() += o.place_clearance;
  if (ctx.held_pieces) {
    // A mesh object is checked as its pieces' boxes, which reach below its lowest point: set down,
    // it is not checked against the surface it is set on, and may overlap its neighbours' boxes
    // as much as when it was lifted.
    ps.attached_padding = -kPiecesLiftTolerance;
    double low = INFINITY;
    for (const ConvexPiece& piece : *ctx.held_pieces)
      for (const Vec3& v : piece.vertices) low = std::min(low, (T_obj_place * v).z());
    for (const Obstacle& s : ctx.statics) {
      const double top = s.T_world.translation().z() + s.T_world.linear().row(2).cwiseAbs().dot(s.size);
      if (s.type == Obstacle::Type::kBox && top <= low + kSupportTolerance) ps.attached_ignore.push_back(s.name);
    }
    descending = wallPaddedChecker(ctx, ps, down_padding);
  }
  const Pose T_tcp_now = ctx.robot.fk(q_lift);
  const double yaw_now = yawOf(T_tcp_now.linear());
  // Held from above, the hand may be set down as tilted as it holds the object (a grasp from the
  // points may be tilted up to 52 degrees), or 45 degrees if that is more.
  const double max_tilt = std::max(M_PI / 4, std::acos(std::clamp(-T_tcp_now.linear()(2, 2), -1.0, 1.0)) + 1e-6);
  struct Option {
    double cost;
    Pose T_tcp, T_target;  // the TCP there, and the object's target it realizes
    double turn;           // [rad] that target turned about the vertical from the one asked
  };
  std::vector<Option> options;
  // Held from the side, the hand stays near horizontal: a cylinder turned about its axis by
  // 30 degree steps (both ways up), the least wrist turn first.
  std::vector<Mat3> symmetries;
  if (ctx.held_shape == ObjectShape::kCylinder) {
    for (double flip : {0.0, M_PI})
      for (int k = 0; k < 12; ++k) symmetries.push_back(Mat3(rotX(flip) * rotZ(k * M_PI / 6)));
  } else if (ctx.held_shape == ObjectShape::kMesh) {  // no symmetry declared: as it is held (its target set above)
    symmetries.push_back(Mat3::Identity());
    // Or, where any yaw will do, turned about the vertical in 30 degree steps, the least turn first
    // (the object frame's image of the world's vertical: S = R^T rotZ R).
    if (o.place_any_yaw)
      for (int k : kTurns) symmetries.push_back(T_obj_place.linear().transpose() * rotZ(k * M_PI / 6) * T_obj_place.linear());
  } else {
    symmetries = boxSymmetries(half);
  }
  for (size_t s = 0; s < symmetries.size(); ++s) {
    Mat3 S = symmetries[s];
    if (ctx.held_shape == ObjectShape::kBox && S(2, 2) > 0.5) {  // a turn about the vertical: the exact rotZ of k quarter turns
      const long k = (std::lround(std::atan2(S(1, 0), S(0, 0)) / (M_PI / 2)) + 4) % 4;
      S = rotZ(2 * M_PI * static_cast<double>(k) / 4);
    }
    Pose T_obj = T_obj_place;
    T_obj.linear() = T_obj_place.linear() * S;
    const Pose T_tcp = T_obj * ctx.T_tcp_held.inverse();
    const double tilt = std::acos(std::clamp(-T_tcp.linear()(2, 2), -1.0, 1.0));
    // A box's symmetries realize the target itself; a mesh object's turns (any yaw) are targets of their own, tried in turn.
    Pose T_realized = T_target;
    double turn = 0, later = 0;
    if (ctx.held_shape == ObjectShape::kMesh) {
      T_realized.linear() = T_obj.linear();
      turn = s == 0 ? 0.0 : kTurns[s - 1] * M_PI / 6;
      later = 10.0 * static_cast<double>(s);
    }
    if (ctx.held_from_side) {
      if (std::abs(tilt - M_PI / 2) > M_PI / 4) continue;
      options.push_back({later + angleBetween(T_tcp.linear(), T_tcp_now.linear()), T_tcp, T_realized, turn});
      continue;
    }
    if (tilt > max_tilt) continue;
    options.push_back({later + std::abs(wrapAngle(yawOf(T_tcp.linear()) - yaw_now)) + 2 * tilt, T_tcp, T_realized, turn});
  }
  std::stable_sort(options.begin(), options.end(), [](const Option& a, const Option& b) { return a.cost < b.cost; });
  Failure last{"place_pose_ik", FailureKind::kIk, "no IK solution for any place pose"};
  // The first option whose hand rises from it with the planner's padding; else the first that
  // rises with less (its fingers opening within millimetres of the tray's wall, which the arm's
  // tracking error may close).
  bool found = false;
  VecX q_preplace;
  CartesianPath descend, retreat, descend_chosen, retreat_chosen;
  double release_opening = travel, opening_chosen = travel;
  Pose T_chosen = T_target;
  double turn_chosen = 0;
  for (const Option& option : options) {
    const Pose& T_place = option.T_tcp;
    Pose T_pre = T_place;
    T_pre.translation().z() += o.approach_distance;
    const IkResult pre = ikFar(ctx, T_pre, q_lift);
    if (!pre.ok()) {
      last = {"place_pose_ik", FailureKind::kIk, "pre-place: " + pre.reason};
      continue;
    }
    if (!carrying->isValid(pre.q())) {
      last = {"place_pose_ik", FailureKind::kCollision, "pre-place configuration in collision (" + carrying->lastCollision() + ")"};
      continue;
    }
    descend = planCartesianLine(ctx.robot, *descending, pre.q(), T_place, ikNear(ctx), o.cartesian);
    if (!descend.ok) {
      last = {"place", descend.kind, descend.reason};
      continue;
    }
    // Retreat: fingers open, the placed object left behind (between the fingers, not checked).
    // Fully open; or, beside objects placed before, only just letting go (tight_margin wider
    // than the object, else finger_margin).
    Pose T_up = T_place;
    T_up.translation().z() += o.retreat_distance;
    // With a tight margin (clutter), last the same opening checked with that margin as padding, as
    // the tight approach is: the fingers rise straight up within millimetres of the neighbours.
    const double let_go = o.tight_margin > 0 ? std::min(o.tight_margin, o.finger_margin) : o.finger_margin;
    const double just = std::min(travel, ctx.out.grasp_opening + let_go);
    std::vector<std::pair<double, double>> tries{{travel, o.padding}, {just, o.padding}};
    if (down_padding < o.padding) tries.push_back({just, down_padding});  // the fingertips near the tray's floor
    if (o.tight_margin > 0 && o.tight_margin < down_padding) tries.push_back({just, o.tight_margin});
    double padding_used = 0;
    for (const auto& [opening, padding] : tries) {
      PlanningScene rs = planningScene(ctx, ctx.held, false);
      rs.finger_opening = opening;
      auto retreating = wallPaddedChecker(ctx, rs, padding);
      retreat = planCartesianLine(ctx.robot, *retreating, descend.waypoints.back(), T_up, ikNear(ctx), o.cartesian);
      ctx.out.collision_checks += retreating->checks();
      release_opening = opening;
      padding_used = padding;
      if (retreat.ok) break;
    }
    if (!retreat.ok) {
      last = {"retreat", retreat.kind, retreat.reason};
      continue;
    }
    const bool roomy = padding_used >= o.padding;
    if (found && !roomy) continue;  // the first one rising with less room is kept
    q_preplace = pre.q();
    descend_chosen = descend;
    retreat_chosen = retreat;
    opening_chosen = release_opening;
    T_chosen = option.T_target;
    turn_chosen = option.turn;
    found = true;
    if (roomy) break;
  }
  if (!found) return done(last);
  st->compute_seconds = since(t);
  ctx.out.plan_place_time += st->compute_seconds;
  const auto t_connect_start = Clock::now();
  st = &ctx.stage("connect_place");
  JointTrajectory t_connect;
  Failure f = connect(ctx, "connect_place", *carrying, carrying_scene, q_lift, q_preplace, t_connect);
  ctx.out.collision_checks += carrying->checks() + descending->checks();
  auto done_connect = [&](const Failure& r) {
    st->compute_seconds = since(t_connect_start);
    ctx.out.plan_place_time += st->compute_seconds;
    return r.ok() ? r : ctx.fail(r);
  };
  if (!f.ok()) return done_connect(f);
  const double dt = ctx.hw.period();
  JointTrajectory t_descend = cartesianTrajectory(ctx.robot, descend_chosen, ikNear(ctx), o.scaling, o.cartesian, dt);
  JointTrajectory t_retreat;
  if (!t_descend.empty()) {
    const VecX q_placed = endOf(t_descend);  // the retreat starts where the descent ends
    t_retreat = cartesianTrajectory(ctx.robot, retreat_chosen, ikNear(ctx), o.scaling, o.cartesian, dt, &q_placed);
  }
  if (t_descend.empty() || t_retreat.empty())
    return done_connect({t_descend.empty() ? "place" : "retreat", FailureKind::kTimeParameterization,
                         "no smooth time parameterization of the straight line"});
  JointTrajectory connect_whole = blendIntoLine(ctx, t_connect, t_descend, *carrying);
  const VecX q_down = endOf(t_descend), q_retreated = endOf(t_retreat);
  out = Plan{};
  out.q_start = q_lift;
  out.name = "place";
  out.bucket = TimeBucket::kPlace;
  out.steps.push_back(trajectoryStep("move_preplace", std::move(t_connect), 0.0, true));
  out.steps.back().stop_path = std::move(connect_whole);
  out.steps.push_back(trajectoryStep("place", std::move(t_descend), 0.0, true));
  out.steps.back().guarded = true;  // the held object meeting the surface early is touch-down, not a fault
  out.q_end = q_down;
  out.object = ctx.held;
  out.T_world_target = T_chosen;
  out.place_turn = turn_chosen;
  out.places = true;
  if (release) {
    PlanStep open = gripperStep("open_gripper_release", q_down, opening_chosen);
    open.release = true;
    out.steps.push_back(open);
    out.steps.push_back(markerStep("detach", PlanStep::Kind::kMarker));
    out.steps.push_back(trajectoryStep("retreat", std::move(t_retreat), opening_chosen, false));
    out.q_end = q_retreated;
  }
  if (ctx.faults) ctx.faults->onPlanned(ctx, out);
  return done_connect({});
}

std::vector<Vec3> placeGridOffsets(const TaskOptions& o) {
  std::vector<std::pair<double, Vec3>> cells;
  for (int row = 0; row < o.place_rows; ++row)
    for (int col = 0; col < o.place_columns; ++col) {
      const Vec3 offset((col - 0.5 * (o.place_columns - 1)) * o.place_pitch, (row - 0.5 * (o.place_rows - 1)) * o.place_pitch, 0);
      cells.push_back({offset.norm(), offset});
    }
  std::stable_sort(cells.begin(), cells.end(), [](const auto& a, const auto& b) { return a.first < b.first - 1e-12; });
  std::vector<Vec3> out;
  for (const auto& [distance, offset] : cells) out.push_back(offset);
  return out;
}

int nextFreeSlot(const std::vector<Vec3>& slots, const std::vector<Vec3>& placed, const std::vector<Vec3>& failed, double pitch) {
  auto near = [&](const Vec3& a, const Vec3& b) { return (a - b).head<2>().norm() < 0.5 * pitch; };
  int best = -1;
  long fewest = std::numeric_limits<long>::max();
  for (size_t i = 0; i < slots.size(); ++i) {
    if (std::any_of(placed.begin(), placed.end(), [&](const Vec3& p) { return near(p, slots[i]); })) continue;
    const long n = std::count_if(failed.begin(), failed.end(), [&](const Vec3& f) { return near(f, slots[i]); });
    if (n < fewest) fewest = n, best = static_cast<int>(i);
  }
  return best;
}

}  // namespace mm
