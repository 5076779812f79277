// Plans executed: the steps of a plan one after another on the hardware as a Motion the executor
// advances period by period (halted by the tree: a controlled stop), its end booked into the
// context; and the tree-less chain of the actions, the reference the trees are compared with.
#include "task/pick_place.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/error.h"
#include "grasp/grasp.h"
#include "planning/blend.h"
#include "planning/chomp.h"
#include "planning/time_parameterization.h"
#include "sim/hardware.h"
#include "task/plan_steps.h"

namespace mm {

namespace {

// ---- execution of a plan ---------------------------------------------------------------------

// The plan's steps one after another on the hardware, each recorded as a stage with its
// simulated time; the held object watched for a drop while carried.
class PlanExecution final : public Motion {
 public:
  PlanExecution(TrialContext& ctx, Plan plan) : ctx_(ctx), plan_(std::move(plan)) {}

  bool command(Hardware& hw) override {
    if (!started()) {
      begin(hw);
      // A plan starts where it was planned from: never a jump of the setpoint (a plan made
      // before the arm moved or braked elsewhere fails here instead).
      if (plan_.q_start.size() > 0 && (plan_.q_start - hw.commandedPositions()).cwiseAbs().maxCoeff() > kStartTolerance) {
        stage_name_ = plan_.steps.empty() ? plan_.name : plan_.steps.front().stage;
        ctx_.stage(stage_name_);
        fail(hw, Failure{stage_name_, FailureKind::kPrecondition,
                         "the arm is not where the " + plan_.name + " plan starts (it moved since it was planned)"});
        return false;
      }
    }
    for (;;) {
      if (current_) {
        if (current_->running() && current_->command(hw)) return true;
        endStep(hw);
        if (!running()) return false;
      }
      if (halted_ || next_ >= plan_.steps.size()) {
        succeed(hw);
        return false;
      }
      startStep(hw);
    }
  }

  void observe(Hardware& hw) override {
    current_->observe(hw);
    account(hw);
    if (!current_->running()) endStep(hw);
  }

  void halt(Hardware& hw) override {
    if (!running()) return;
    halted_ = true;
    if (current_) current_->halt(hw);
  }

  const Plan& plan() const { return plan_; }
  const std::string& stageName() const { return stage_name_; }

 private:
  void startStep(Hardware& hw) {
    const PlanStep& s = plan_.steps[next_++];
    ctx_.picking = plan_.name == "pick" && ctx_.held < 0 ? plan_.object : -1;
    stage_name_ = s.stage;
    stage_index_ = ctx_.out.stages.size();
    ctx_.stage(s.stage);
    step_ = &s;
    hw.setStiff(s.kind == PlanStep::Kind::kTrajectory && s.stiff);
    const double force = ctx_.options.grasp_force;
    switch (s.kind) {
      case PlanStep::Kind::kTrajectory: {
        step_start_ = hw.time();
        next_look_ = hw.time() + ctx_.options.scene_update_period;
        StepMonitor monitor = [this, holding = s.holding] {
          Failure f = holding ? dropCheck() : Failure{};
          return f.ok() ? pathCheck() : f;
        };
        // A contact task (the push) raises the force limit, as Franka users raise the collision
        // thresholds (setCollisionBehavior) for contact-rich motions.
        // The arm is held at a move's end until still (1 mrad, 1 mrad/s; at most 0.3 s); unless
        // motion.settle_every_move is off, where only the gripper acting next (the grasp, the
        // release) or a push needs it: another move hands on as the last setpoint is sent.
        const bool gripper_next = next_ < plan_.steps.size() && plan_.steps[next_].kind == PlanStep::Kind::kGripper;
        const bool settle = ctx_.options.settle_every_move || gripper_next || s.stiff || plan_.name == "push";
        auto motion = std::make_unique<TrajectoryMotion>(
            s.trajectory, s.opening, force, monitor, ctx_.robot, settle ? 0.3 : 0.0, ctx_.options.path_tolerance,
            s.stiff ? ctx_.options.push_force_limit : ctx_.options.contact_force_limit, s.guarded);
        motion->setSettleTolerance(1e-3, ctx_.options.settle_velocity);
        if (!s.stop_path.empty()) motion->stopAlong(s.stop_path);
        if (gripper_next && ctx_.options.close_early && !plan_.steps[next_].release && plan_.steps[next_].opening < s.opening)
          motion->closeWhileSettling(plan_.steps[next_].opening, force);
        current_ = std::move(motion);
        ctx_.gripper_opening = s.opening;
        break;
      }
      case PlanStep::Kind::kGripper:
        // The place steps before this one brought the object over its target.
        if (s.release && plan_.places) ctx_.over_target = plan_.T_world_target, ctx_.over_target_turn = plan_.place_turn;
        if (s.release && ctx_.held_truth >= 0) {
          // In-hand slip, a metric from the simulator's truth: where the object sits in the hand as the
          // fingers begin to open, against where it sat when they closed.
          const TruthScope metric(hw, "in-hand slip");
          const Pose T_tcp_obj = hw.tcpPose().inverse() * hw.object(ctx_.held_truth).T_world_object;
          ctx_.held_record.in_hand_slip = (T_tcp_obj.translation() - ctx_.T_tcp_held_actual.translation()).norm();
        }
        // Detach before opening, as the source's task (weld mode: the attach plugin).
        if (s.release && ctx_.held_truth >= 0 && ctx_.options.weld) hw.attach(ctx_.held_truth, false);
        {
          auto gripper = std::make_unique<GripperMotion>(s.q_hold, s.opening, force);
          // A release hands on to the retreat once the pads are 3 mm clear of the object's faces;
          // the fingers open on to their goal as the arm rises.
          if (s.release && ctx_.held >= 0 && ctx_.held_record.grasp_opening > 0)
            gripper->doneWhenOpenTo(std::min(s.opening, ctx_.held_record.grasp_opening + kReleaseClearance));
          current_ = std::move(gripper);
        }
        ctx_.gripper_opening = s.opening;
        break;
      case PlanStep::Kind::kAttach:
        current_.reset();
        attach(hw);
        break;
      case PlanStep::Kind::kMarker:
        current_.reset();
        break;
    }
  }

  // Metrics of each step, from the simulator's truth (never used to decide): the largest external
  // force, touches of objects other than the one picked or held (an episode per onset), and how far
  // the other objects moved while one was picked.
  void account(Hardware& hw) {
    const TruthScope metrics(hw, "the step's metrics");
    TrialOutcome& out = ctx_.out;
    const int target = ctx_.truthIndex(plan_.object), held = ctx_.held_truth;
    // As the protective stop sees it: sustained for two control periods (a contact's one-step
    // impulse is not counted).
    if (const double f = hw.externalForce(); std::isfinite(f)) {
      out.max_external_force = std::max(out.max_external_force, std::min(f, last_external_force_));
      last_external_force_ = f;
    }
    for (int o : hw.objectsTouched()) {
      // An episode: its onset counts once; touches within 0.1 s of the last belong to it.
      const auto [it, first] = ctx_.last_touch.try_emplace(o, -1e9);
      if (o != target && o != held && hw.time() - it->second > 0.1) ++out.non_target_contacts;
      it->second = hw.time();
    }
    if (plan_.name != "pick" || plan_.object < 0) return;
    if (start_positions_.empty())
      for (const ObjectState& o : hw.objects()) start_positions_.emplace_back(o.index, o.T_world_object.translation());
    double moved = 0;
    for (const auto& [index, p] : start_positions_)
      if (index != target && index != held) moved = std::max(moved, (hw.object(index).T_world_object.translation() - p).norm());
    out.neighbours_moved = std::max(out.neighbours_moved, moved);
    if (held >= 0 && held == target) ctx_.held_record.neighbours_moved = std::max(ctx_.held_record.neighbours_moved, moved);
  }

  // Books the step that ended; fails the whole execution where it failed.
  void endStep(Hardware& hw) {
    if (!current_) return;
    std::unique_ptr<Motion> m = std::move(current_);
    const PlanStep& s = *step_;
    hw.setStiff(false);  // a push's gains, or a protective stop's brake, end with the step
    StageRecord& st = ctx_.out.stages[stage_index_];
    st.sim_seconds = m->duration();
    ctx_.executeBucket(plan_.bucket) += m->duration();
    ctx_.out.max_tracking_error = std::max(ctx_.out.max_tracking_error, m->maxTrackingError());
    const bool attempt = s.kind == PlanStep::Kind::kGripper && s.expected_opening > 0;  // a pick's closing on its grasp
    if (attempt) beginAttempt(hw);
    if (m->state() == MotionState::kFailed) {
      if (attempt) endAttempt("missed");
      if (s.kind == PlanStep::Kind::kGripper && s.release) letGo();
      if (m->failure().kind == FailureKind::kDropped) lost();
      Failure f = m->failure();
      f.stage = s.stage;
      return fail(hw, f);
    }
    if (m->halted()) {  // the tree stopped it (its time budget)
      if (attempt) endAttempt("halted");
      return;
    }
    if (s.guarded && static_cast<const TrajectoryMotion&>(*m).touchedDown()) reanchor(hw, s);
    if (s.kind == PlanStep::Kind::kGripper) {
      const double opening = static_cast<GripperMotion&>(*m).opening();
      if (s.release) letGo();
      if (s.take_hold && ctx_.held < 0 && opening >= kEmptyGrip) takeHoldOfObjectBetweenFingers(hw);
      if (s.expected_opening > 0) {
        ctx_.out.grasp_opening = opening;
        ctx_.held_record.grasp_opening = opening;
        if (opening < 0.5 * s.expected_opening || opening < kEmptyGrip) {
          endAttempt("missed");
          ctx_.failed_grasps.push_back(plan_.T_world_grasp);
          return fail(hw, Failure{s.stage, FailureKind::kGraspMissed,
                                  "nothing between the fingers (closed to " + std::to_string(opening * 1000) + " mm)"});
        }
        if (opening > s.expected_opening + 0.005) {
          endAttempt("missed");
          return fail(hw, Failure{s.stage, FailureKind::kGraspMissed,
                                  "the fingers did not close (still " + std::to_string(opening * 1000) + " mm open)"});
        }
      }
    }
  }

  // A guarded step ended at touch-down, short of its planned end: the rest of the plan (the release
  // held there, the retreat from there) moves by the same joint offset, so nothing jumps back down
  // to the planned bottom, and the plan ends where the arm really is.
  void reanchor(Hardware& hw, const PlanStep& s) {
    const VecX offset = hw.commandedPositions() - s.trajectory.q.col(s.trajectory.size() - 1);
    for (size_t k = next_; k < plan_.steps.size(); ++k) {
      PlanStep& later = plan_.steps[k];
      if (later.q_hold.size() == offset.size()) later.q_hold += offset;
      if (later.trajectory.size() > 0) later.trajectory.q.colwise() += offset;
    }
    if (plan_.q_end.size() == offset.size()) plan_.q_end += offset;
  }

  void attach(Hardware& hw) {
    const int truth = objectInFingers(hw, ctx_.truthIndex(plan_.object));
    if (truth < 0) {  // the fingers closed where no object is
      endAttempt("missed");
      return;
    }
    hold(hw, plan_.object, truth, plan_.object_half, plan_.T_tcp_object, plan_.grasp_candidates_tried, plan_.object_shape,
         plan_.grasp_type, plan_.object_pieces);
  }

  // A grasp attempt begins as the fingers close on a chosen candidate: on the object meant, else
  // (scored from the simulator's truth) the one nearest the TCP.
  void beginAttempt(const Hardware& hw) {
    if (ctx_.attempt_open) endAttempt(ctx_.held >= 0 ? "held_at_end" : "missed");  // never taken over by a later one
    ctx_.out.grasp_attempts.push_back({objectInFingers(hw, ctx_.truthIndex(plan_.object)), "held_at_end"});
    ctx_.attempt_open = true;
  }
  void endAttempt(const char* result) {
    if (!ctx_.attempt_open) return;
    ctx_.out.grasp_attempts.back().result = result;
    ctx_.attempt_open = false;
  }

  // The simulator's bookkeeping of what the fingers closed on (for the records, the weld and the
  // drop monitor): the object the robot meant, when it is one; else, a false detection's, the real
  // object nearest the TCP (within 3 cm), or none. A segment (camera mode, no model) was matched
  // to the truth loosely (within its footprint's half diagonal: a segment of two objects, or of a
  // part of one, may have been matched to the wrong one): when the robot touches objects but not
  // the one meant, it holds the touched one nearest the TCP.
  int objectInFingers(const Hardware& hw, int meant) const {
    const TruthScope bookkeeping(hw, "what the fingers closed on");
    const std::vector<ObjectState> world = hw.objects();
    if (segmentedObjects(ctx_.perception)) {
      const std::vector<int> touched = hw.objectsTouched();
      if (!touched.empty() && std::find(touched.begin(), touched.end(), meant) == touched.end()) {
        int nearest = -1;
        double best = INFINITY;
        for (const ObjectState& o : world) {
          if (std::find(touched.begin(), touched.end(), o.index) == touched.end()) continue;
          const double d = (o.T_world_object.translation() - hw.tcpPose().translation()).norm();
          if (d < best) best = d, nearest = o.index;
        }
        if (nearest >= 0) return nearest;
      }
    }
    if (std::any_of(world.begin(), world.end(), [&](const ObjectState& o) { return o.index == meant; })) return meant;
    int object = -1;
    double best = 0.03;
    for (const ObjectState& o : world) {
      const double d = (o.T_world_object.translation() - hw.tcpPose().translation()).norm();
      if (d < best) best = d, object = o.index;
    }
    return object;
  }

  // The fingers closed on something: the perceived object nearest the TCP (within 2 cm), if any.
  void takeHoldOfObjectBetweenFingers(Hardware& hw) {
    const Pose T_tcp = ctx_.robot.fk(hw.jointPositions());
    const ObjectState* best = nullptr;
    double best_d = 0.02;
    for (const ObjectState& o : ctx_.objects) {
      const double d = (o.T_world_object.translation() - T_tcp.translation()).norm();
      if (d <= best_d && !picked(ctx_, o.index)) best_d = d, best = &o;
    }
    if (!best) return;
    const int truth = objectInFingers(hw, ctx_.truthIndex(best->index));
    if (truth >= 0) hold(hw, best->index, truth, best->half_size, T_tcp.inverse() * best->T_world_object, 0, best->shape, "", best->pieces);
  }

  // A box closed on by parallel pads at a small angle to its faces (a yaw-offset grasp) turns until
  // its faces lie on the pads: when the fingers close, or at the latest when it is let go of on
  // the tray. The robot expects the box squared on the pads (turned about the approach axis, the
  // TCP's z, so that its axis nearest the closing axis, the TCP's y, lies along it), so that a
  // place puts it at the target's orientation either way.
  // A mesh solid likewise when the pads close on two parallel faces of it (the closing line's
  // contact normals opposite): it turns until those faces lie on the pads.
  static Pose squaredInHand(const Pose& T_tcp_object, ObjectShape shape, const std::shared_ptr<const std::vector<ConvexPiece>>& pieces) {
    if (shape == ObjectShape::kMesh && pieces) {
      ObjectState o;
      o.shape = shape;
      o.pieces = pieces;
      o.T_world_object = T_tcp_object;  // in the TCP's frame: the fingers close along y through its origin
      double t1, t2;
      Vec3 n1, n2;
      if (!lineThroughObject(o, Vec3::Zero(), Vec3::UnitY(), t1, t2, n1, n2) || n1.dot(n2) > -std::cos(3.0 * M_PI / 180) ||
          std::abs(n2.z()) > std::sin(15.0 * M_PI / 180))
        return T_tcp_object;
      const double turn = wrapAngle(M_PI / 2 - std::atan2(n2.y(), n2.x()));
      if (std::abs(turn) > 20.0 * M_PI / 180 || std::abs(turn) < 1e-6) return T_tcp_object;
      Pose squared = T_tcp_object;
      squared.linear() = rotZ(turn) * T_tcp_object.linear();
      squared.translation() = rotZ(turn) * T_tcp_object.translation();
      return squared;
    }
    if (shape != ObjectShape::kBox) return T_tcp_object;
    const Mat3& R = T_tcp_object.linear();
    int a = 0;
    for (int k = 1; k < 3; ++k)
      if (std::abs(R(1, k)) > std::abs(R(1, a))) a = k;
    const Vec3 axis = R.col(a);
    if (std::abs(axis.z()) > std::sin(15.0 * M_PI / 180)) return T_tcp_object;  // not across the pads
    const double turn = std::atan2(axis.x(), std::abs(axis.y())) * (axis.y() >= 0 ? 1.0 : -1.0);
    if (std::abs(turn) > 20.0 * M_PI / 180 || std::abs(turn) < 1e-6) return T_tcp_object;  // square already: as planned
    Pose squared = T_tcp_object;
    squared.linear() = rotZ(turn) * R;
    return squared;
  }

  // The robot holds its object `object`; the simulator's bookkeeping says it is `truth`.
  void hold(Hardware& hw, int object, int truth, const Vec3& half, const Pose& T_tcp_object, int candidates_tried, ObjectShape shape,
            const std::string& grasp_type, std::shared_ptr<const std::vector<ConvexPiece>> pieces) {
    ctx_.held = object;
    ctx_.held_truth = truth;
    if (ctx_.attempt_open) ctx_.out.grasp_attempts.back().object = truth;
    if (std::find(ctx_.picked.begin(), ctx_.picked.end(), object) == ctx_.picked.end()) ctx_.picked.push_back(object);
    // Let go of away from a target before, picked again now: that record is superseded.
    auto& picks = ctx_.out.picks;
    picks.erase(std::remove_if(picks.begin(), picks.end(), [&](const PickRecord& p) { return p.object == truth && !p.at_target; }),
                picks.end());
    ctx_.T_tcp_held = squaredInHand(T_tcp_object, shape, pieces);
    {
      const TruthScope metric(hw, "the grasp as achieved");
      ctx_.T_tcp_held_actual = hw.tcpPose().inverse() * hw.object(truth).T_world_object;
    }
    PickRecord r;
    r.object = truth;
    r.half_size = half;
    r.grasp_candidates_tried = candidates_tried;
    r.grasp_opening = ctx_.out.grasp_opening;
    r.grasp_type = grasp_type;
    // The source's grasp-pose deviation: the achieved in-hand pose against the planned one (a
    // metric from the simulator's truth, never used by the pipeline).
    r.grasp_deviation = (ctx_.T_tcp_held_actual.translation() - T_tcp_object.translation()).norm();
    r.grasp_deviation_angle = objectSymmetricAngle(ctx_.T_tcp_held_actual.linear(), T_tcp_object.linear(), shape, half);
    ctx_.held_shape = shape;
    r.pieces = pieces;
    ctx_.held_pieces = std::move(pieces);
    // Held from the side: the hand near horizontal when the fingers closed (a tilted box's grasp
    // leans at most 50 degrees).
    ctx_.held_from_side = -ctx_.robot.fk(hw.jointPositions()).linear()(2, 2) < std::cos(70.0 * M_PI / 180);
    ctx_.held_record = r;
    if (ctx_.options.weld) hw.attach(truth, true);
    if (ctx_.options.payload_compensation)
      for (const ObjectState& o : ctx_.objects)
        if (o.index == object) hw.setPayload(o.mass, T_tcp_object.translation());
  }

  // The gripper let go of the held object: over its target when a place brought it there; else
  // it is back in the world, to be perceived and picked again.
  void letGo() {
    if (ctx_.held < 0) return;
    // The servo carries the object's weight until the fingers have opened (Franka's setLoad after
    // the gripper's move): dropped as the opening begins, the arm sagged under the still-held
    // object by 0.3 mm in x and y (the place error's last systematic part).
    ctx_.hw.setPayload(0, Vec3::Zero());
    PickRecord r = ctx_.held_record;
    r.at_target = ctx_.over_target.has_value();
    if (ctx_.attempt_open && ctx_.out.grasp_attempts.back().object == ctx_.held_truth) endAttempt(r.at_target ? "in_tray" : "let_go_elsewhere");
    if (r.at_target) {
      r.T_world_target = *ctx_.over_target;
      r.place_turn = ctx_.over_target_turn;
      r.first_pass = ctx_.out.failures.size() == ctx_.failures_at_last_place;
      ctx_.failures_at_last_place = ctx_.out.failures.size();
      ctx_.milestone("place");
    } else {
      forget(ctx_.held);
    }
    ctx_.out.picks.push_back(r);
    ctx_.held = ctx_.held_truth = -1;
    ctx_.over_target.reset();
  }

  // The held object left the hand (a drop): no longer held, back in the world.
  void lost() {
    if (ctx_.held < 0) return;
    endAttempt("dropped");
    if (ctx_.options.weld && ctx_.held_truth >= 0) ctx_.hw.attach(ctx_.held_truth, false);
    ctx_.hw.setPayload(0, Vec3::Zero());
    forget(ctx_.held);
    ctx_.held = ctx_.held_truth = -1;
    ctx_.over_target.reset();
  }

  void forget(int object) {
    ctx_.picked.erase(std::remove(ctx_.picked.begin(), ctx_.picked.end(), object), ctx_.picked.end());
  }

  // The planning scene monitor: every scene_update_period the robot senses obstacles; when they
  // changed, the rest of the path (from the sample being tracked) is checked against them.
  Failure pathCheck() {
    const double period = ctx_.options.scene_update_period;
    if (!(period > 0) || ctx_.hw.time() < next_look_ - 1e-9) return {};
    next_look_ += period;
    if (!ctx_.senseObstacles() || ctx_.seen_obstacles.empty()) return {};
    const JointTrajectory& traj = step_->trajectory;
    if (traj.size() == 0) return {};
    PlanningScene scene;
    scene.obstacles = ctx_.seen_obstacles;
    if (ctx_.held >= 0) {
      attachObject(scene, ctx_.held_record.half_size, ctx_.T_tcp_held, ctx_.held_pieces);
    }
    scene.finger_opening = step_->opening;
    auto checker = makeChecker("fcl", ctx_.robot, scene, 0.0);
    const int from = std::clamp(static_cast<int>(std::lround((ctx_.hw.time() - step_start_) / traj.dt)), 0, traj.size() - 1);
    const int last = traj.size() - 1;
    for (int k = from;; k = std::min(k + 5, last)) {  // every 10 ms of the path
      if (!checker->isValid(traj.q.col(k)))
        return {"", FailureKind::kPathBlocked,
                "an obstacle sensed during the motion blocks the rest of the path (" + checker->lastCollision() + " at " +
                    std::to_string(static_cast<int>(100.0 * k / std::max(1, last))) + "%)"};
      if (k == last) return {};
    }
  }

  // The simulator's drop monitor.
  Failure dropCheck() {
    if (ctx_.held_truth < 0) return {};
    const Hardware& hw = ctx_.hw;
    const TruthScope monitor(hw, "the drop monitor");
    const Pose T_tcp_obj = hw.tcpPose().inverse() * hw.object(ctx_.held_truth).T_world_object;
    const double d = (T_tcp_obj.translation() - ctx_.T_tcp_held_actual.translation()).norm();
    if (d > ctx_.options.drop_distance)
      return {"", FailureKind::kDropped, "dropped: object " + std::to_string(int(d * 1000)) + " mm from its in-hand pose"};
    return {};
  }

  TrialContext& ctx_;
  std::vector<std::pair<int, Vec3>> start_positions_;  // a pick's objects where they were at its first step
  double step_start_ = 0, next_look_ = 0;  // the trajectory step's start; the next obstacle sensing
  double last_external_force_ = 0;         // [N] the previous period's
  Plan plan_;
  size_t next_ = 0, stage_index_ = 0;
  const PlanStep* step_ = nullptr;
  std::unique_ptr<Motion> current_;
  std::string stage_name_;
};

}  // namespace

// ---- execution -------------------------------------------------------------------------------

std::unique_ptr<Motion> executePlan(TrialContext& ctx, Plan plan) {
  return std::make_unique<PlanExecution>(ctx, std::move(plan));
}

Failure finishExecution(TrialContext& ctx, Motion& m) {
  auto& e = static_cast<PlanExecution&>(m);
  MM_DEMAND(!e.running());
  const bool pick = e.plan().name == "pick";
  if (e.state() == MotionState::kFailed) {
    ctx.q_rest = ctx.hw.commandedPositions();
    if (pick) ctx.failed_pick_at = e.plan().T_world_grasp.translation();
    return ctx.fail(e.failure());
  }
  if (e.halted()) {
    ctx.q_rest = ctx.hw.commandedPositions();
    return ctx.fail({e.stageName(), FailureKind::kHalted, "halted by the behavior tree"});
  }
  if (pick) ctx.failed_pick_at.reset();
  ctx.q_rest = e.plan().q_end;
  if (e.plan().places && ctx.held >= 0) ctx.over_target = e.plan().T_world_target, ctx.over_target_turn = e.plan().place_turn;  // placed but not let go of
  if (e.plan().name == "pick" || e.plan().name == "home") ctx.milestone(e.plan().name);
  return {};
}

Failure runMotion(TrialContext& ctx, std::unique_ptr<Motion> m) {
  Failure result;
  bool done = false;
  ctx.executor.start(std::move(m), [&](Motion& ended) {
    result = finishExecution(ctx, ended);
    done = true;
  });
  while (!done) ctx.executor.step();
  return result;
}

void runPickAndPlace(TrialContext& ctx, const Pose& T_world_target) {
  auto chain = [&]() -> bool {
    if (!detectObjects(ctx).ok()) return false;
    const int i = mostAccessibleObject(ctx);
    if (i < 0) return ctx.fail({"perception", FailureKind::kPerception, "no object detected"}), false;
    const ObjectState target = ctx.objects[i];
    GraspSolution grasp;
    Plan plan;
    if (const Failure f = selectGrasp(ctx, target, graspCandidates(ctx, target), 0, grasp); !f.ok()) return ctx.fail(f), false;
    return planPick(ctx, grasp, plan).ok() &&
           runMotion(ctx, executePlan(ctx, std::move(plan))).ok() && planPlace(ctx, T_world_target, true, plan).ok() &&
           runMotion(ctx, executePlan(ctx, std::move(plan))).ok() && planHome(ctx, plan).ok() &&
           runMotion(ctx, executePlan(ctx, std::move(plan))).ok();
  };
  finishTrial(ctx, chain());
}

}  // namespace mm
