// The end of a trial: the objects settle, each one let go of is measured against its target in
// the simulator, and the outcome is filled in (success, failure, errors, times, counts).
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

// ---- the end of a trial ----------------------------------------------------------------------

void finishTrial(TrialContext& ctx, bool tree_succeeded) {
  TrialOutcome& out = ctx.out;
  Hardware& hw = ctx.hw;
  while (ctx.executor.busy()) ctx.executor.step();  // a stop still braking
  const TruthScope scoring(hw, "the evaluation");
  // Let what was let go of come to rest, then measure it in the simulator, never assumed.
  bool evaluated_ok = true;
  if (!out.picks.empty() && !hw.unstable()) {
    StageRecord& st = ctx.stage("evaluate");
    HoldMotion hold(ctx.q_rest, ctx.gripper_opening, ctx.options.grasp_force, ctx.options.settle_time);
    runToEnd(hw, hold);
    st.sim_seconds = hold.duration();
    if (hold.state() == MotionState::kFailed) {
      Failure f = hold.failure();
      f.stage = "evaluate";
      ctx.fail(f);
      evaluated_ok = false;
    }
  }
  Failure evaluation;
  // An object the robot had no model of (camera mode, segmented) was placed as what it saw: the
  // columns under its points, whose middle is not the object's origin and whose axes are not its
  // own. Where it came to rest on the tray is judged; its orientation and height have no target
  // (its orientation error: -1), nor its origin one to 2 cm. Set down at a slot of the place grid
  // (ComputePlacePosition), it is judged as the clutter-removal protocol judges a grasp (released in
  // the tray), in that slot: its frame's origin (its bounding box's centre) within half the pitch of
  // the slot's centre along x and y. Elsewhere (a fixed target, a grid of one slot): the position
  // tolerance, as a known object.
  const bool no_model = segmentedObjects(ctx.perception);
  if (no_model) out.place_orientation_error = -1;
  const double slot_half = ctx.options.place_rows * ctx.options.place_columns > 1 ? ctx.options.place_pitch / 2 : 0.0;
  for (PickRecord& p : out.picks) {
    if (!evaluated_ok) break;
    if (!p.at_target) {
      p.reason = "let go of away from a place target";
      if (evaluation.ok()) evaluation = {"evaluate", FailureKind::kDropped, "object " + std::to_string(p.object) + " " + p.reason};
      continue;
    }
    const ObjectState o = hw.object(p.object);
    const Vec3 pos = o.T_world_object.translation(), goal = p.T_world_target.translation();
    p.offset = pos - goal;
    p.position_error = (pos - goal).head<2>().norm();
    p.orientation_error = objectSymmetricAngle(o.T_world_object.linear(), p.T_world_target.linear(), o.shape, o.half_size);
    const double rest_error = std::abs(pos.z() - goal.z());
    const double speed = hw.objectVelocity(p.object).norm();
    const bool by_slot = no_model && slot_half > 0 && std::any_of(ctx.place_slots.begin(), ctx.place_slots.end(), [&](const Vec3& s) {
                           return (s - goal).head<2>().norm() < 1e-6;
                         });
    if (by_slot && std::max(std::abs(p.offset.x()), std::abs(p.offset.y())) > slot_half)
      p.reason = "object " + std::to_string(p.position_error * 1000) + " mm from the place target, out of its slot (" +
                 std::to_string(slot_half * 1000) + " mm each way)";
    else if (!by_slot && p.position_error > ctx.options.tolerance_position)
      p.reason = "object " + std::to_string(p.position_error * 1000) + " mm from the place target";
    else if (!no_model && p.orientation_error > ctx.options.tolerance_orientation)
      p.reason = "object orientation off by " + std::to_string(p.orientation_error * 180 / M_PI) + " deg";
    else if (!no_model && rest_error > 0.01)
      p.reason = "object not resting on the target surface (height off by " + std::to_string(rest_error * 1000) + " mm)";
    else if (speed > 0.01)
      p.reason = "object still moving (" + std::to_string(speed) + " m/s)";
    p.placed = p.reason.empty();
    if (!p.placed && evaluation.ok()) evaluation = {"evaluate", FailureKind::kPlacement, p.reason};
    out.place_position_error = std::max(out.place_position_error, p.position_error);
    if (no_model)
      p.orientation_error = -1;
    else
      out.place_orientation_error = std::max(out.place_orientation_error, p.orientation_error);
    out.in_hand_slip = std::max(out.in_hand_slip, p.in_hand_slip);
  }
  if (tree_succeeded && evaluated_ok) {
    if (evaluation.ok() && out.picks.empty())
      evaluation = {"evaluate", FailureKind::kPlacement, "the tree succeeded without placing any object"};
    if (evaluation.ok() && ctx.held_truth >= 0)
      evaluation = {"evaluate", FailureKind::kPlacement, "the tree ended with an object in the hand"};
    if (evaluation.ok()) {
      out.success = true;
      out.failure_stage.clear();
      out.failure_reason.clear();
      out.failure_kind = FailureKind::kNone;
    } else {
      ctx.fail(evaluation);
    }
  }
  out.objects_left_in_bin = objectsInBinTruly(ctx);
  // Why the robot left each one: its reason for the object it took for it (its own id for it).
  std::map<int, std::string> why_not;
  for (const auto& [id, reason] : ctx.why_not)
    if (const int truth = ctx.truthIndex(id); truth >= 0) why_not[truth] = reason;
  for (const ObjectState& o : hw.objects()) {
    if (o.index == ctx.held_truth || !insideCrop(o, ctx.perception)) continue;
    LeftRecord l;
    l.object = o.index;
    l.position = o.T_world_object.translation();
    double up = 0;
    for (int a = 0; a < 3; ++a) up = std::max(up, std::abs(o.T_world_object.linear()(2, a)));
    l.tilt = std::acos(std::min(1.0, up));
    const auto why = why_not.find(o.index);
    l.reason = why != why_not.end() ? why->second : "not tried";
    out.left.push_back(l);
  }
  out.collision_count = hw.collisionEvents();
  out.collision_log = hw.collisionLog();
  out.sim_time = ctx.simTime();
  out.compute_time = 0;
  for (const StageRecord& s : out.stages) out.compute_time += s.compute_seconds;
  out.total_time = out.perception_time + out.plan_pick_time + out.execute_pick_time + out.plan_place_time +
                   out.execute_place_time + out.return_home_time;
  for (RecordedFailure& r : out.failures)
    if (r.handled && r.failure.kind != FailureKind::kHalted) ++out.recovery_attempts;
  out.recovery_needed = out.recovery_attempts > 0;
  out.recovery_success = out.recovery_needed && out.success;
}

}  // namespace mm
