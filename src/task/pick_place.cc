#include "task/pick_place.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/error.h"
#include "planning/blend.h"
#include "planning/chomp.h"
#include "planning/time_parameterization.h"
#include "sim/hardware.h"

namespace mm {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kSupportTolerance = 0.003;  // [m] held object may touch its support this much
constexpr double kLimitMargin = 0.05;        // [rad] grasp and place solutions keep off the limits
// [rad] A plan's start and where the arm was last sent. Known seam: a plan that follows a
// straight-line move starts from the line's last IK waypoint, while the arm was sent to the last
// sample of that line's trajectory (IK from the previous 2 ms sample): up to 2.2 mrad apart on
// the quickstart (measured), which is the 0.0022 rad "max tracking error" it reports. Left as it
// is so that the outcomes stay those of the recorded chain; this check catches real jumps.
constexpr double kStartTolerance = 0.01;

// Where a trajectory leaves the arm. A straight line's last sample is its own IK solution of the
// goal, reached from the line's previous samples: for a redundant arm it may differ (in the null
// space) from the waypoint the line was planned to, so plans end, and hold, where their
// trajectories end.
VecX endOf(const JointTrajectory& t) { return t.q.col(t.size() - 1); }
constexpr double kReleaseClearance = 0.003;  ///< [m] per finger: the pads this far off the object end a release
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

Obstacle boxOf(const ObjectState& o) {
  Obstacle b;
  b.type = o.shape == ObjectShape::kCylinder ? Obstacle::Type::kCylinder : Obstacle::Type::kBox;
  b.size = o.shape == ObjectShape::kCylinder ? Vec3(o.half_size.x(), o.half_size.z(), 0) : o.half_size;
  b.T_world = o.T_world_object;
  b.name = o.name;
  return b;
}

// Angle between two box orientations, modulo the box's symmetry about its vertical axis.
bool picked(const TrialContext& ctx, int index) {
  return std::find(ctx.picked.begin(), ctx.picked.end(), index) != ctx.picked.end();
}

// The world as the planner knows it: the static cell, the obstacles sensed, the perceived objects not yet picked (but
// `exclude`), the objects let go of at their targets (but `exclude`), and the held object when
// `attached`.
PlanningScene planningScene(const TrialContext& ctx, int exclude, bool attached) {
  PlanningScene s;
  s.obstacles = ctx.statics;
  s.obstacles.insert(s.obstacles.end(), ctx.seen_obstacles.begin(), ctx.seen_obstacles.end());
  for (const ObjectState& o : ctx.objects)
    if (o.index != exclude && !picked(ctx, o.index)) s.obstacles.push_back(boxOf(o));
  for (const PickRecord& p : ctx.out.picks)
    if (p.at_target && p.object != exclude) {
      ObjectState placed;
      placed.index = p.object;
      placed.name = "placed_" + std::to_string(p.object);
      placed.half_size = p.half_size;
      placed.T_world_object = p.T_world_target;
      s.obstacles.push_back(boxOf(placed));
    }
  if (attached && ctx.held >= 0) {
    s.has_attached = true;
    s.attached_half = ctx.held_record.half_size;
    s.T_tcp_attached = ctx.T_tcp_held;
    s.finger_opening = ctx.held_record.half_size.y();
  }
  return s;
}

IkFunction ikNear(TrialContext& ctx, Rng& rng) {
  return [&ctx, &rng](const Pose& T, const VecX& seed, VecX& q) {
    IkRequest one = ctx.options.ik;
    one.target = T;
    one.seed = seed;
    one.max_attempts = 1;  // a single descent from the seed: stay on its branch
    one.limit_margin = 0.0;
    // Converged far below the control period's resolution: samples 2 ms apart are differentiated
    // twice, so IK noise of 1e-5 rad would read as accelerations of several rad/s^2.
    one.tol_position = 1e-10;
    one.tol_rotation = 1e-9;
    const IkResult r = ctx.ik_near->solve(one, rng);
    if (r.ok()) q = r.q();
    return r.ok();
  };
}
IkFunction ikNear(TrialContext& ctx) { return ikNear(ctx, ctx.rng_ik); }

// The configured solver, from `seed`, kept `kLimitMargin` inside the limits, nearest the seed.
IkResult ikFar(TrialContext& ctx, const Pose& T, const VecX& seed, Rng& rng) {
  IkRequest req = ctx.options.ik;
  req.target = T;
  req.seed = seed;
  req.limit_margin = kLimitMargin;
  req.nearest = true;  // the least joint motion from where the arm will be
  return ctx.ik->solve(req, rng);
}
IkResult ikFar(TrialContext& ctx, const Pose& T, const VecX& seed) { return ikFar(ctx, T, seed, ctx.rng_ik); }

// A joint-space path from `start` to `goal` (the optional optimizer after the planner, CHOMP,
// counts as planning) and its time parameterization. `checker` validated the path: it also judges
// the samples of methods that leave the straight segments, which back off where one is invalid.
Failure connect(TrialContext& ctx, const std::string& stage, CollisionChecker& checker, const PlanningScene& scene,
                const VecX& start, const VecX& goal, JointTrajectory& out) {
  if (ctx.faults && ctx.faults->failPlanning(ctx, stage))
    return {stage, FailureKind::kPlanning, "planner " + ctx.options.planner.planner + ": no solution (injected fault)"};
  PlanResult r = planJointPath(ctx.robot, checker, start, goal, ctx.rng_plan.next(), ctx.options.planner);
  if (ctx.options.optimizer == "chomp" && r.ok) r.path = chompSmooth(ctx.robot, scene, checker, r.path).path;
  if (!r.ok) return {stage, r.kind, r.reason};
  TimedPath t = timeParameterize(ctx.options.time_parameterization, r.path, ctx.robot, ctx.options.scaling,
                                 ctx.hw.period(), [&](const VecX& q) { return checker.isValid(q); });
  if (t.trajectory.empty()) return {stage, FailureKind::kTimeParameterization, t.failure};
  out = std::move(t.trajectory);
  ctx.milestone("plan:" + stage);
  return {};
}

// Blends the joint-space move `connect` into the straight line after it (motion.blend_radius,
// planning/blend.h), the blended samples checked with `checker`. Returns the whole of `connect`
// as it was when it now ends moving (the path a stop brakes along), else an empty trajectory.
JointTrajectory blendIntoLine(TrialContext& ctx, JointTrajectory& connect, JointTrajectory& line, CollisionChecker& checker) {
  const TaskOptions& o = ctx.options;
  if (o.blend_radius <= 0 || o.settle_every_move) return {};
  JointTrajectory whole = connect;
  const long checks = checker.checks();
  const int k = blendJunction(connect, line, ctx.robot, {o.blend_radius, o.scaling}, [&](const VecX& q) { return checker.isValid(q); });
  ctx.out.collision_checks += checker.checks() - checks;
  return k > 0 ? whole : JointTrajectory{};
}

PlanStep trajectoryStep(const std::string& stage, JointTrajectory t, double opening, bool holding) {
  PlanStep s;
  s.kind = PlanStep::Kind::kTrajectory;
  s.stage = stage;
  s.trajectory = std::move(t);
  s.opening = opening;
  s.holding = holding;
  return s;
}

PlanStep gripperStep(const std::string& stage, const VecX& q_hold, double opening) {
  PlanStep s;
  s.kind = PlanStep::Kind::kGripper;
  s.stage = stage;
  s.q_hold = q_hold;
  s.opening = opening;
  return s;
}

PlanStep markerStep(const std::string& stage, PlanStep::Kind kind) {
  PlanStep s;
  s.kind = kind;
  s.stage = stage;
  return s;
}

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
        if (s.release && plan_.places) ctx_.over_target = plan_.T_world_target;
        if (s.release && ctx_.held >= 0) {
          // In-hand slip, a metric from the simulator's truth: where the object sits in the hand as the
          // fingers begin to open, against where it sat when they closed.
          const Pose T_tcp_obj = hw.tcpPose().inverse() * hw.object(ctx_.held).T_world_object;
          ctx_.held_record.in_hand_slip = (T_tcp_obj.translation() - ctx_.T_tcp_held_actual.translation()).norm();
        }
        // Detach before opening, as the source's task (weld mode: the attach plugin).
        if (s.release && ctx_.held >= 0 && ctx_.options.weld) hw.attach(ctx_.held, false);
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
    TrialOutcome& out = ctx_.out;
    // As the protective stop sees it: sustained for two control periods (a contact's one-step
    // impulse is not counted).
    if (const double f = hw.externalForce(); std::isfinite(f)) {
      out.max_external_force = std::max(out.max_external_force, std::min(f, last_external_force_));
      last_external_force_ = f;
    }
    for (int o : hw.objectsTouched()) {
      // An episode: its onset counts once; touches within 0.1 s of the last belong to it.
      const auto [it, first] = ctx_.last_touch.try_emplace(o, -1e9);
      if (o != plan_.object && o != ctx_.held && hw.time() - it->second > 0.1) ++out.non_target_contacts;
      it->second = hw.time();
    }
    if (plan_.name != "pick" || plan_.object < 0) return;
    if (start_positions_.empty())
      for (const ObjectState& o : hw.objects()) start_positions_.emplace_back(o.index, o.T_world_object.translation());
    double moved = 0;
    for (const auto& [index, p] : start_positions_)
      if (index != plan_.object && index != ctx_.held) moved = std::max(moved, (hw.object(index).T_world_object.translation() - p).norm());
    out.neighbours_moved = std::max(out.neighbours_moved, moved);
    if (ctx_.held == plan_.object) ctx_.held_record.neighbours_moved = std::max(ctx_.held_record.neighbours_moved, moved);
  }

  // Books the step that ended; fails the whole execution where it failed.
  void endStep(Hardware& hw) {
    if (!current_) return;
    std::unique_ptr<Motion> m = std::move(current_);
    const PlanStep& s = *step_;
    if (s.stiff) hw.setStiff(false);
    StageRecord& st = ctx_.out.stages[stage_index_];
    st.sim_seconds = m->duration();
    ctx_.executeBucket(plan_.bucket) += m->duration();
    ctx_.out.max_tracking_error = std::max(ctx_.out.max_tracking_error, m->maxTrackingError());
    if (m->state() == MotionState::kFailed) {
      if (s.kind == PlanStep::Kind::kGripper && s.release) letGo();
      if (m->failure().kind == FailureKind::kDropped) lost();
      Failure f = m->failure();
      f.stage = s.stage;
      return fail(hw, f);
    }
    if (m->halted()) return;
    if (s.guarded && static_cast<const TrajectoryMotion&>(*m).touchedDown()) reanchor(hw, s);
    if (s.kind == PlanStep::Kind::kGripper) {
      const double opening = static_cast<GripperMotion&>(*m).opening();
      if (s.release) letGo();
      if (s.take_hold && ctx_.held < 0 && opening >= 0.003) takeHoldOfObjectBetweenFingers(hw);
      if (s.expected_opening > 0) {
        ctx_.out.grasp_opening = opening;
        ctx_.held_record.grasp_opening = opening;
        if (opening < 0.5 * s.expected_opening || opening < 0.003) {
          ctx_.failed_grasps.push_back(plan_.T_world_grasp);
          return fail(hw, Failure{s.stage, FailureKind::kGraspMissed,
                                  "nothing between the fingers (closed to " + std::to_string(opening * 1000) + " mm)"});
        }
        if (opening > s.expected_opening + 0.005)
          return fail(hw, Failure{s.stage, FailureKind::kGraspMissed,
                                  "the fingers did not close (still " + std::to_string(opening * 1000) + " mm open)"});
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
    int object = plan_.object;
    const std::vector<ObjectState> world = hw.objects();
    if (std::none_of(world.begin(), world.end(), [&](const ObjectState& o) { return o.index == object; })) {
      // The object the robot meant is not there (a phantom detection): what the fingers closed on
      // is the real object nearest the TCP.
      object = -1;
      double best = 0.03;
      for (const ObjectState& o : world) {
        const double d = (o.T_world_object.translation() - hw.tcpPose().translation()).norm();
        if (d < best) best = d, object = o.index;
      }
      if (object < 0) return;
    }
    hold(hw, object, plan_.object_half, plan_.T_tcp_object, plan_.grasp_candidates_tried, plan_.object_shape, plan_.grasp_type);
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
    if (best) hold(hw, best->index, best->half_size, T_tcp.inverse() * best->T_world_object, 0, best->shape, "");
  }

  void hold(Hardware& hw, int object, const Vec3& half, const Pose& T_tcp_object, int candidates_tried, ObjectShape shape,
            const std::string& grasp_type) {
    ctx_.held = object;
    if (std::find(ctx_.picked.begin(), ctx_.picked.end(), object) == ctx_.picked.end()) ctx_.picked.push_back(object);
    // Let go of away from a target before, picked again now: that record is superseded.
    auto& picks = ctx_.out.picks;
    picks.erase(std::remove_if(picks.begin(), picks.end(), [&](const PickRecord& p) { return p.object == object && !p.at_target; }),
                picks.end());
    ctx_.T_tcp_held = T_tcp_object;
    ctx_.T_tcp_held_actual = hw.tcpPose().inverse() * hw.object(object).T_world_object;
    PickRecord r;
    r.object = object;
    r.half_size = half;
    r.grasp_candidates_tried = candidates_tried;
    r.grasp_opening = ctx_.out.grasp_opening;
    r.grasp_type = grasp_type;
    // The source's grasp-pose deviation: the achieved in-hand pose against the planned one (a
    // metric from the simulator's truth, never used by the pipeline).
    r.grasp_deviation = (ctx_.T_tcp_held_actual.translation() - T_tcp_object.translation()).norm();
    r.grasp_deviation_angle = objectSymmetricAngle(ctx_.T_tcp_held_actual.linear(), T_tcp_object.linear(), shape, half);
    ctx_.held_shape = shape;
    // Held from the side: the hand near horizontal when the fingers closed (a tilted box's grasp
    // leans at most 50 degrees).
    ctx_.held_from_side = -hw.tcpPose().linear()(2, 2) < std::cos(70.0 * M_PI / 180);
    ctx_.held_record = r;
    if (ctx_.options.weld) hw.attach(object, true);
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
    // object by 0.3 mm in x and y (issue 13, the place error's last systematic part).
    ctx_.hw.setPayload(0, Vec3::Zero());
    PickRecord r = ctx_.held_record;
    r.at_target = ctx_.over_target.has_value();
    if (r.at_target) {
      r.T_world_target = *ctx_.over_target;
      r.first_pass = ctx_.out.failures.size() == ctx_.failures_at_last_place;
      ctx_.failures_at_last_place = ctx_.out.failures.size();
      ctx_.milestone("place");
    } else {
      forget(ctx_.held);
    }
    ctx_.out.picks.push_back(r);
    ctx_.held = -1;
    ctx_.over_target.reset();
  }

  // The held object left the hand (a drop): no longer held, back in the world.
  void lost() {
    if (ctx_.held < 0) return;
    if (ctx_.options.weld) ctx_.hw.attach(ctx_.held, false);
    ctx_.hw.setPayload(0, Vec3::Zero());
    forget(ctx_.held);
    ctx_.held = -1;
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
      scene.has_attached = true;
      scene.attached_half = ctx_.held_record.half_size;
      scene.T_tcp_attached = ctx_.T_tcp_held;
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

  Failure dropCheck() {
    if (ctx_.held < 0) return {};
    const Hardware& hw = ctx_.hw;
    const Pose T_tcp_obj = hw.tcpPose().inverse() * hw.object(ctx_.held).T_world_object;
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

// ---- perception ------------------------------------------------------------------------------

namespace {

// Camera mode: the camera's depth image through detectBoxes. A detection gets the identity of the
// true object nearest it (within 3 cm) for the trial's bookkeeping and its pose errors; the pose
// the robot uses is the camera's. A detection near no object (a false one) is recorded and left
// out; an object in the bin no detection found is counted as missed.
PerceptionResult perceiveByCamera(TrialContext& ctx, const std::vector<ObjectState>& truth) {
  const PerceptionOptions& o = ctx.perception;
  PerceptionResult p;
  Frame frame;
  std::string why;
  if (!ctx.hw.capture(o.camera, o.camera_width, o.camera_height, frame, &why)) {
    p.reason = "camera '" + o.camera + "': " + why;
    return p;
  }
  if (o.calibrated) frame.camera.T_world_camera = o.T_world_camera;  // where calibration says it is
  CameraPerceptionOptions co;
  co.T_world_crop = o.T_world_crop;
  co.crop_half = o.crop_half;
  co.crop_height = o.crop_height;
  const CameraPerceptionResult r = detectBoxes(frame, o.shapes, co, ctx.rng_perception);
  std::vector<char> taken(truth.size(), 0);
  for (const CameraDetection& d : r.detections) {
    int best = -1;
    double best_dist = 0.03;
    for (size_t i = 0; i < truth.size(); ++i) {
      const double dist = (truth[i].T_world_object.translation() - d.object.T_world_object.translation()).norm();
      if (!taken[i] && dist < best_dist) best = static_cast<int>(i), best_dist = dist;
    }
    DetectionRecord rec;
    rec.time = ctx.simTime();
    if (best < 0) {
      rec.centre_error = rec.rotation_error = rec.mssd = -1;
      ctx.out.detections.push_back(rec);
      continue;
    }
    taken[static_cast<size_t>(best)] = 1;
    const ObjectState& t = truth[static_cast<size_t>(best)];
    const PoseError e = poseError(d.object.T_world_object, t.T_world_object, t.half_size);
    rec.object = t.index;
    rec.centre_error = e.centre, rec.rotation_error = e.rotation, rec.mssd = e.mssd;
    ctx.out.detections.push_back(rec);
    ObjectState seen = d.object;
    seen.index = t.index;
    seen.name = t.name;
    p.objects.push_back(seen);
  }
  for (size_t i = 0; i < truth.size(); ++i)
    if (!taken[i] && insideCrop(truth[i], o)) ++ctx.out.missed_detections;
  p.ok = !p.objects.empty();
  if (!p.ok) p.reason = r.ok ? "no object detected" : r.reason;
  return p;
}

}  // namespace

Failure detectObjects(TrialContext& ctx) {
  StageRecord& st = ctx.stage("perception");
  const auto t = Clock::now();
  std::vector<ObjectState> truth;
  for (const ObjectState& o : ctx.hw.objects())
    if (o.index != ctx.held) truth.push_back(o);
  PerceptionResult p = ctx.perception.mode == PerceptionMode::kCamera ? perceiveByCamera(ctx, truth)
                                                                      : perceive(truth, ctx.perception, ctx.rng_perception);
  if (ctx.faults) ctx.faults->onPerception(ctx, p);
  ctx.senseObstacles();
  st.compute_seconds = since(t);
  ctx.out.perception_time += st.compute_seconds;
  if (!p.ok) return ctx.fail({"perception", FailureKind::kPerception, p.reason});
  ctx.milestone("perception");
  const bool first = ctx.objects.empty() && ctx.picked.empty();
  ctx.objects = p.objects;
  if (first) ctx.out.objects_in_bin = static_cast<int>(ctx.objects.size());
  return {};
}

std::vector<int> objectsByRoom(const TrialContext& ctx) {
  std::vector<std::pair<double, int>> order;
  for (size_t i = 0; i < ctx.objects.size(); ++i) {
    const ObjectState& a = ctx.objects[i];
    if (picked(ctx, a.index)) continue;
    double room = 1.0;
    for (const ObjectState& b : ctx.objects)
      if (a.index != b.index && !picked(ctx, b.index))
        room = std::min(room, (a.T_world_object.translation() - b.T_world_object.translation()).head<2>().norm());
    order.push_back({room, static_cast<int>(i)});
  }
  std::stable_sort(order.begin(), order.end(), [](const auto& x, const auto& y) { return x.first > y.first; });
  std::vector<int> out;
  for (const auto& [room, i] : order) out.push_back(i);
  return out;
}

int mostAccessibleObject(TrialContext& ctx) {
  const std::vector<int> order = objectsByRoom(ctx);
  for (int i : order)
    if (graspable(ctx, ctx.objects[i])) return i;
  return order.empty() ? -1 : order.front();
}

int perceivedObjectAt(const TrialContext& ctx, const Pose& T_world_object) {
  int best = -1;
  double best_d = 0.05;
  for (size_t i = 0; i < ctx.objects.size(); ++i) {
    const double d = (ctx.objects[i].T_world_object.translation() - T_world_object.translation()).norm();
    if (d <= best_d && !picked(ctx, ctx.objects[i].index)) best_d = d, best = static_cast<int>(i);
  }
  return best;
}

int objectsInBin(const TrialContext& ctx) {
  int n = 0;
  for (const ObjectState& o : ctx.hw.objects())
    if (o.index != ctx.held && insideCrop(o, ctx.perception)) ++n;
  return n;
}

// ---- pick ------------------------------------------------------------------------------------

std::vector<GraspCandidate> graspCandidates(TrialContext& ctx, const ObjectState& object) {
  std::vector<Obstacle> neighbours = ctx.statics;
  for (const ObjectState& b : ctx.objects)
    if (b.index != object.index && !picked(ctx, b.index)) neighbours.push_back(boxOf(b));
  const double preferred_yaw = yawOf(ctx.robot.fk(ctx.robot.home()).linear());
  const GraspOptions go = graspOptionsFor(ctx.robot.spec().gripper, ctx.options);
  return mm::graspCandidates(object, preferred_yaw, Vec3::Zero(), neighbours, go);
}

GraspOptions graspOptionsFor(const GripperSpec& gripper, const TaskOptions& task) {
  GraspOptions go = task.grasp;
  go.max_opening = 2 * gripper.travel;
  go.friction = gripper.pad_friction;
  go.approach_distance = task.approach_distance;
  // The pads: the +y finger's first box, in the TCP frame (z along the approach).
  for (const ShapeSpec& sh : gripper.fingers[0].shapes)
    if (sh.type == ShapeSpec::Type::kBox) {
      go.pad_half_width = sh.half[0];
      go.pad_z_min = gripper.finger_z + sh.pos[2] - sh.half[2] - gripper.tcp_offset;
      go.pad_z_max = gripper.finger_z + sh.pos[2] + sh.half[2] - gripper.tcp_offset;
      break;
    }
  // The hand body: its front (nearest the TCP) and its half extents across.
  double front = -INFINITY, thick = 0, wide = 0;
  for (const ShapeSpec& sh : gripper.hand.shapes) {
    if (sh.type == ShapeSpec::Type::kMesh) {  // its hull's vertices, placed
      const Pose T = makePose(Vec3(sh.pos[0], sh.pos[1], sh.pos[2]), Quat(sh.quat[0], sh.quat[1], sh.quat[2], sh.quat[3]));
      for (const Vec3& v : meshHull(sh.mesh, Vec3(sh.scale[0], sh.scale[1], sh.scale[2]))->vertices) {
        const Vec3 p = T * v;
        front = std::max(front, p.z()), thick = std::max(thick, std::abs(p.x())), wide = std::max(wide, std::abs(p.y()));
      }
    } else if (sh.type == ShapeSpec::Type::kBox) {
      front = std::max(front, sh.pos[2] + sh.half[2]);
      thick = std::max(thick, std::abs(sh.pos[0]) + sh.half[0]);
      wide = std::max(wide, std::abs(sh.pos[1]) + sh.half[1]);
    } else {
      const double r = sh.radius;
      const double z = sh.type == ShapeSpec::Type::kSphere ? sh.pos[2] + r : std::max(sh.from[2], sh.to[2]) + (sh.type == ShapeSpec::Type::kCapsule ? r : 0.0);
      front = std::max(front, z);
      thick = std::max(thick, r);
      wide = std::max(wide, r);
    }
  }
  if (std::isfinite(front)) go.hand_back = gripper.tcp_offset - front;
  if (thick > 0) go.hand_half_thickness = thick, go.hand_half_width = wide;
  return go;
}

namespace {

// The checks a grasp candidate must pass (pre-grasp IK and no collision there, a straight
// collision-free approach and lift), with the checkers of selectGrasp; fills `out`'s motions.
struct GraspCheckers {
  std::unique_ptr<CollisionChecker> full, no_target;
};

// `margin`: the fingers open this much wider than the object; the tight pass (margin below
// finger_margin) also checks with that padding.
GraspCheckers graspCheckers(const TrialContext& ctx, const ObjectState& object, double margin) {
  const TaskOptions& o = ctx.options;
  PlanningScene full_scene = planningScene(ctx, -1, false), approach_scene = planningScene(ctx, object.index, false);
  const double widest = 2 * std::max(object.half_size.x(), object.half_size.y());
  full_scene.finger_opening = approach_scene.finger_opening = std::min(ctx.robot.spec().gripper.travel, widest / 2 + margin);
  const double padding = margin < o.finger_margin ? std::min(o.padding, margin) : o.padding;
  return {makeChecker(o.checker, ctx.robot, full_scene, padding), makeChecker(o.checker, ctx.robot, approach_scene, padding)};
}

// The finger margins to try in turn: the configured one, then the tight one in clutter.
std::vector<double> graspMargins(const TaskOptions& o) {
  std::vector<double> m{o.finger_margin};
  if (o.tight_margin > 0 && o.tight_margin < o.finger_margin) m.push_back(o.tight_margin);
  return m;
}

Failure tryGrasp(TrialContext& ctx, const ObjectState& object, const GraspCandidate& g, GraspCheckers& checkers,
                 double approach_distance, Rng& rng, GraspSolution& out, long& collision_checks) {
  const TaskOptions& o = ctx.options;
  const Pose& T_grasp = g.T_world_tcp;
  Pose T_pre = T_grasp;
  T_pre.translation() += approach_distance * g.approach;
  const IkResult pre = ikFar(ctx, T_pre, ctx.robot.home(), rng);
  if (!pre.ok()) return {"grasp_pose_ik", FailureKind::kIk, "pre-grasp: " + pre.reason};
  if (!checkers.full->isValid(pre.q()))
    return {"grasp_pose_ik", FailureKind::kCollision, "pre-grasp configuration in collision (" + checkers.full->lastCollision() + ")"};
  const IkFunction near = ikNear(ctx, rng);
  out.approach = planCartesianLine(ctx.robot, *checkers.no_target, pre.q(), T_grasp, near, o.cartesian);
  if (!out.approach.ok) return {"approach", out.approach.kind, out.approach.reason};
  out.q_pre = pre.q();
  out.q_grasp = out.approach.waypoints.back();
  out.T_tcp_object = T_grasp.inverse() * object.T_world_object;
  // Lift with the object attached; it leaves the bin floor it rests on.
  PlanningScene ls = planningScene(ctx, object.index, false);
  ls.has_attached = true;
  ls.attached_half = object.half_size;
  ls.T_tcp_attached = out.T_tcp_object;
  ls.finger_opening = object.half_size.y();
  ls.attached_padding = -kSupportTolerance;
  auto lifting = makeChecker(o.checker, ctx.robot, ls, o.padding);
  Pose T_lift = T_grasp;
  T_lift.translation().z() += o.lift_height;
  out.lift = planCartesianLine(ctx.robot, *lifting, out.q_grasp, T_lift, near, o.cartesian);
  collision_checks += lifting->checks();
  if (!out.lift.ok) return {"lift", out.lift.kind, out.lift.reason};
  return {};
}

}  // namespace

bool graspable(TrialContext& ctx, const ObjectState& object) {
  // A probe: its own copy of the IK stream and no record, so that choosing leaves the trial's
  // planning exactly as it would be without it.
  Rng rng = ctx.rng_ik;
  const auto candidates = graspCandidates(ctx, object);
  long checks = 0;
  for (double margin : graspMargins(ctx.options)) {
    GraspCheckers checkers = graspCheckers(ctx, object, margin);
    int tried = 0;
    for (const GraspCandidate& g : candidates) {
      if (!g.rejected.empty()) break;  // the rest are out of force closure too
      if (tried++ >= ctx.options.max_grasp_candidates) break;
      GraspSolution s;
      if (tryGrasp(ctx, object, g, checkers, ctx.options.approach_distance, rng, s, checks).ok()) return true;
    }
  }
  return false;
}

Failure selectGrasp(TrialContext& ctx, const ObjectState& object, const std::vector<GraspCandidate>& candidates,
                    size_t first, GraspSolution& out, double approach_distance) {
  const TaskOptions& o = ctx.options;
  if (approach_distance < 0) approach_distance = o.approach_distance;
  const double travel = ctx.robot.spec().gripper.travel;
  const auto t = Clock::now();
  StageRecord* st = &ctx.stage("grasp_pose_ik");
  if (ctx.out.target_object < 0) ctx.out.target_object = object.index;
  auto done = [&](const Failure& f) {
    st->compute_seconds = since(t);
    ctx.out.plan_pick_time += st->compute_seconds;
    st->ok = f.ok();
    return f;
  };
  // filterGrasps: the score (force closure), then IK, collision, the approach and the lift; each
  // candidate looked at is recorded with what became of it.
  GraspSelection& sel = ctx.out.grasp_selections.emplace_back();
  sel.object = object.index;
  sel.shape = shapeName(object.shape);
  sel.candidates = static_cast<int>(candidates.size());
  auto note = [&](const GraspCandidate& g, const std::string& result) {
    sel.tried.push_back({graspTypeName(g.type), g.score, g.closure_margin, g.contact_area, g.torque_arm, g.clearance, result});
  };
  if (candidates.empty())
    return done({"grasp_pose_ik", FailureKind::kNoGrasp, "no grasp for this object (tilted, or too wide for the stroke)"});
  Failure last{"grasp_pose_ik", FailureKind::kNoGrasp, "every grasp candidate failed before in this trial"};
  if (!candidates[first < candidates.size() ? first : 0].rejected.empty())
    last = {"grasp_pose_ik", FailureKind::kNoGrasp, "no candidate in force closure: " + candidates[first < candidates.size() ? first : 0].rejected};
  bool found = false;
  for (double margin : graspMargins(o)) {
    GraspCheckers checkers = graspCheckers(ctx, object, margin);
    int tried = 0;
    for (size_t c = first; c < candidates.size() && tried < o.max_grasp_candidates; ++c) {
      const GraspCandidate& g = candidates[c];
      if (!g.rejected.empty()) {  // sorted last: none after it is in force closure
        note(g, g.rejected);
        break;
      }
      const bool failed_before = std::any_of(ctx.failed_grasps.begin(), ctx.failed_grasps.end(), [&](const Pose& T) {
        return (T.translation() - g.T_world_tcp.translation()).norm() < 1e-3 &&
               angleBetween(T.linear(), g.T_world_tcp.linear()) < 1e-2;
      });
      if (failed_before) continue;
      ++tried;
      ++ctx.out.grasp_candidates_tried;
      last = tryGrasp(ctx, object, g, checkers, approach_distance, ctx.rng_ik, out, ctx.out.collision_checks);
      note(g, last.ok() ? "chosen" : last.stage + ": " + last.reason);
      if (!last.ok()) continue;
      found = true;
      out.object = object;
      out.candidate = g;
      out.candidate_index = static_cast<int>(c);
      out.candidates_tried = tried;
      out.approach_distance = approach_distance;
      out.finger_margin = margin;
      ctx.out.grasp_opening = g.width / 2;
      out.pre_opening = std::min(travel, g.width / 2 + margin);
      break;
    }
    ctx.out.collision_checks += checkers.full->checks() + checkers.no_target->checks();
    if (found) break;
  }
  if (!found) {
    last.reason += " (after " + std::to_string(ctx.out.grasp_candidates_tried) + " grasp candidates)";
    ctx.why_not[object.index] = "grasp: " + last.reason;
    return done(last);
  }
  return done({});
}

Failure planPick(TrialContext& ctx, const GraspSolution& g, Plan& out) {
  const TaskOptions& o = ctx.options;
  const double travel = ctx.robot.spec().gripper.travel;
  const auto t = Clock::now();
  StageRecord& st = ctx.stage("connect_pregrasp");
  auto done = [&](const Failure& f) {
    st.compute_seconds = since(t);
    ctx.out.plan_pick_time += st.compute_seconds;
    return f.ok() ? f : ctx.fail(f);
  };
  PlanningScene full_scene = planningScene(ctx, -1, false);
  const double widest = 2 * std::max(g.object.half_size.x(), g.object.half_size.y());
  const double margin = g.finger_margin > 0 ? g.finger_margin : o.finger_margin;
  full_scene.finger_opening = std::min(travel, widest / 2 + margin);
  auto full = makeChecker(o.checker, ctx.robot, full_scene, margin < o.finger_margin ? std::min(o.padding, margin) : o.padding);
  JointTrajectory t_connect;
  const Failure f = connect(ctx, "connect_pregrasp", *full, full_scene, ctx.q_rest, g.q_pre, t_connect);
  ctx.out.collision_checks += full->checks();
  if (!f.ok()) return done(f);
  const double dt = ctx.hw.period();
  JointTrajectory t_approach = cartesianTrajectory(ctx.robot, g.approach, ikNear(ctx), o.scaling, o.cartesian, dt);
  JointTrajectory t_lift;
  if (!t_approach.empty()) {
    const VecX q_grasped = endOf(t_approach);  // the lift starts where the approach ends
    t_lift = cartesianTrajectory(ctx.robot, g.lift, ikNear(ctx), o.scaling, o.cartesian, dt, &q_grasped);
  }
  if (t_approach.empty() || t_lift.empty())
    return done({t_approach.empty() ? "approach" : "lift", FailureKind::kTimeParameterization,
                 "no smooth time parameterization of the straight line"});
  JointTrajectory connect_whole = blendIntoLine(ctx, t_connect, t_approach, *full);
  // The fingers open to the object's half width plus a margin, not wider: in a bin, the room
  // beside the object is what limits a grasp.
  out = Plan{};
  out.q_start = ctx.q_rest;
  out.name = "pick";
  out.bucket = TimeBucket::kPick;
  out.steps.push_back(gripperStep("open_gripper", ctx.q_rest, g.pre_opening));
  out.steps.push_back(trajectoryStep("move_pregrasp", std::move(t_connect), g.pre_opening, false));
  out.steps.back().stop_path = std::move(connect_whole);
  const VecX q_grasp = endOf(t_approach), q_lifted = endOf(t_lift);
  out.steps.push_back(trajectoryStep("approach", std::move(t_approach), g.pre_opening, false));
  PlanStep close = gripperStep("close_gripper", q_grasp, 0.0);
  close.expected_opening = g.candidate.width / 2;
  out.steps.push_back(close);
  out.steps.push_back(markerStep("attach", PlanStep::Kind::kAttach));
  out.steps.push_back(trajectoryStep("lift", std::move(t_lift), 0.0, true));
  out.q_end = q_lifted;
  out.object = g.object.index;
  out.object_half = g.object.half_size;
  out.object_shape = g.object.shape;
  out.grasp_type = graspTypeName(g.candidate.type);
  out.T_tcp_object = g.T_tcp_object;
  out.T_world_grasp = g.candidate.T_world_tcp;
  out.grasp_candidates_tried = g.candidates_tried;
  if (ctx.faults) ctx.faults->onPlanned(ctx, out);
  return done({});
}

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
  // Placing: the held object goes down to the tray with no padding of its own.
  PlanningScene ps = planningScene(ctx, -1, true);
  ps.attached_padding = -kSupportTolerance;
  auto descending = makeChecker(o.checker, ctx.robot, ps, o.padding);
  // TCP poses that put the object at the target, one per symmetry of the box (a cube held on its
  // side is placed on that side) that keeps the hand within 45 deg of pointing down; least wrist
  // turn and tilt first.
  // The target rests the object on the place surface: its centre the held object's own half
  // height above it.
  Pose T_target = T_world_object;
  if (ctx.target_half_height >= 0) T_target.translation().z() += half.z() - ctx.target_half_height;
  Pose T_obj_place = T_target;
  T_obj_place.translation().z() += o.place_clearance;
  const Pose T_tcp_now = ctx.robot.fk(q_lift);
  const double yaw_now = yawOf(T_tcp_now.linear());
  std::vector<std::pair<double, Pose>> options;
  // Held from the side, the hand stays near horizontal: a cylinder turned about its axis by
  // 30 degree steps (both ways up), the least wrist turn first.
  std::vector<Mat3> symmetries;
  if (ctx.held_shape == ObjectShape::kCylinder) {
    for (double flip : {0.0, M_PI})
      for (int k = 0; k < 12; ++k) symmetries.push_back(Mat3(rotX(flip) * rotZ(k * M_PI / 6)));
  } else {
    symmetries = boxSymmetries(half);
  }
  for (Mat3 S : symmetries) {
    if (ctx.held_shape == ObjectShape::kBox && S(2, 2) > 0.5) {  // a turn about the vertical: the exact rotZ of k quarter turns
      const long k = (std::lround(std::atan2(S(1, 0), S(0, 0)) / (M_PI / 2)) + 4) % 4;
      S = rotZ(2 * M_PI * static_cast<double>(k) / 4);
    }
    Pose T_obj = T_obj_place;
    T_obj.linear() = T_obj_place.linear() * S;
    const Pose T_tcp = T_obj * ctx.T_tcp_held.inverse();
    const double tilt = std::acos(std::clamp(-T_tcp.linear()(2, 2), -1.0, 1.0));
    if (ctx.held_from_side) {
      if (std::abs(tilt - M_PI / 2) > M_PI / 4) continue;
      options.push_back({angleBetween(T_tcp.linear(), T_tcp_now.linear()), T_tcp});
      continue;
    }
    if (tilt > M_PI / 4) continue;
    options.push_back({std::abs(wrapAngle(yawOf(T_tcp.linear()) - yaw_now)) + 2 * tilt, T_tcp});
  }
  std::stable_sort(options.begin(), options.end(), [](auto& a, auto& b) { return a.first < b.first; });
  Failure last{"place_pose_ik", FailureKind::kIk, "no IK solution for any place pose"};
  bool found = false;
  VecX q_preplace;
  CartesianPath descend, retreat;
  double release_opening = travel;
  for (const auto& [cost, T_place] : options) {
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
    if (o.tight_margin > 0 && o.tight_margin < o.padding) tries.push_back({just, o.tight_margin});
    for (const auto& [opening, padding] : tries) {
      PlanningScene rs = planningScene(ctx, ctx.held, false);
      rs.finger_opening = opening;
      auto retreating = makeChecker(o.checker, ctx.robot, rs, padding);
      retreat = planCartesianLine(ctx.robot, *retreating, descend.waypoints.back(), T_up, ikNear(ctx), o.cartesian);
      ctx.out.collision_checks += retreating->checks();
      release_opening = opening;
      if (retreat.ok) break;
    }
    if (!retreat.ok) {
      last = {"retreat", retreat.kind, retreat.reason};
      continue;
    }
    q_preplace = pre.q();
    found = true;
    break;
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
  JointTrajectory t_descend = cartesianTrajectory(ctx.robot, descend, ikNear(ctx), o.scaling, o.cartesian, dt);
  JointTrajectory t_retreat;
  if (!t_descend.empty()) {
    const VecX q_placed = endOf(t_descend);  // the retreat starts where the descent ends
    t_retreat = cartesianTrajectory(ctx.robot, retreat, ikNear(ctx), o.scaling, o.cartesian, dt, &q_placed);
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
  out.T_world_target = T_target;
  out.places = true;
  if (release) {
    PlanStep open = gripperStep("open_gripper_release", q_down, release_opening);
    open.release = true;
    out.steps.push_back(open);
    out.steps.push_back(markerStep("detach", PlanStep::Kind::kMarker));
    out.steps.push_back(trajectoryStep("retreat", std::move(t_retreat), release_opening, false));
    out.q_end = q_retreated;
  }
  if (ctx.faults) ctx.faults->onPlanned(ctx, out);
  return done_connect({});
}

// ---- home, retreat, gripper ------------------------------------------------------------------

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
    if (f.ok()) out.steps.push_back(trajectoryStep("return_home", std::move(traj), ctx.gripper_opening, ctx.held >= 0));
  }
  ctx.out.collision_checks += checker->checks();
  st.compute_seconds = since(t);
  ctx.out.return_home_time += st.compute_seconds;
  return f.ok() ? f : ctx.fail(f);
}

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

Failure planRetreatUp(TrialContext& ctx, double distance, Plan& out) {
  const TaskOptions& o = ctx.options;
  const auto t = Clock::now();
  StageRecord& st = ctx.stage("plan_safe");
  // The object just let go of stays between the fingers: not checked against them.
  const int just_placed = ctx.out.picks.empty() ? -1 : ctx.out.picks.back().object;
  PlanningScene s = planningScene(ctx, just_placed, true);
  if (ctx.held < 0) s.finger_opening = ctx.gripper_opening;
  // Unpadded: backing out straight up is how the hand leaves a spot where it touches (a missed
  // grasp among the walls), which the padded planner would call a collision from the start. An
  // object the hand starts inside (one it pushed, perceived where it was) is left out: going up
  // is the way off it.
  auto checker = makeChecker(o.checker, ctx.robot, s, 0.0);
  for (int k = 0; k < 4 && !checker->isValid(ctx.q_rest); ++k) {
    const std::string hit = checker->lastCollision();
    const std::string obstacle = hit.substr(hit.find(" / ") == std::string::npos ? 0 : hit.find(" / ") + 3);
    if (std::none_of(ctx.objects.begin(), ctx.objects.end(), [&](const ObjectState& x) { return x.name == obstacle; })) break;
    s.ignore.push_back(obstacle);
    checker = makeChecker(o.checker, ctx.robot, s, 0.0);
  }
  Pose T_up = ctx.robot.fk(ctx.q_rest);
  T_up.translation().z() += distance;
  const CartesianPath up = planCartesianLine(ctx.robot, *checker, ctx.q_rest, T_up, ikNear(ctx), o.cartesian);
  ctx.out.collision_checks += checker->checks();
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

// ---- execution -------------------------------------------------------------------------------

std::unique_ptr<Motion> executePlan(TrialContext& ctx, Plan plan) {
  return std::make_unique<PlanExecution>(ctx, std::move(plan));
}

Failure finishExecution(TrialContext& ctx, Motion& m) {
  auto& e = static_cast<PlanExecution&>(m);
  MM_DEMAND(!e.running());
  if (e.state() == MotionState::kFailed) {
    ctx.q_rest = ctx.hw.commandedPositions();
    return ctx.fail(e.failure());
  }
  if (e.halted()) {
    ctx.q_rest = ctx.hw.commandedPositions();
    return ctx.fail({e.stageName(), FailureKind::kHalted, "halted by the behavior tree"});
  }
  ctx.q_rest = e.plan().q_end;
  if (e.plan().places && ctx.held >= 0) ctx.over_target = e.plan().T_world_target;  // placed but not let go of
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

// ---- the end of a trial ----------------------------------------------------------------------

void finishTrial(TrialContext& ctx, bool tree_succeeded) {
  TrialOutcome& out = ctx.out;
  Hardware& hw = ctx.hw;
  while (ctx.executor.busy()) ctx.executor.step();  // a stop still braking
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
    if (p.position_error > ctx.options.tolerance_position)
      p.reason = "object " + std::to_string(p.position_error * 1000) + " mm from the place target";
    else if (p.orientation_error > ctx.options.tolerance_orientation)
      p.reason = "object orientation off by " + std::to_string(p.orientation_error * 180 / M_PI) + " deg";
    else if (rest_error > 0.01)
      p.reason = "object not resting on the target surface (height off by " + std::to_string(rest_error * 1000) + " mm)";
    else if (speed > 0.01)
      p.reason = "object still moving (" + std::to_string(speed) + " m/s)";
    p.placed = p.reason.empty();
    if (!p.placed && evaluation.ok()) evaluation = {"evaluate", FailureKind::kPlacement, p.reason};
    out.place_position_error = std::max(out.place_position_error, p.position_error);
    out.place_orientation_error = std::max(out.place_orientation_error, p.orientation_error);
    out.in_hand_slip = std::max(out.in_hand_slip, p.in_hand_slip);
  }
  if (tree_succeeded && evaluated_ok) {
    if (evaluation.ok() && out.picks.empty())
      evaluation = {"evaluate", FailureKind::kPlacement, "the tree succeeded without placing any object"};
    if (evaluation.ok() && ctx.held >= 0)
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
  out.objects_left_in_bin = objectsInBin(ctx);
  for (const ObjectState& o : hw.objects()) {
    if (o.index == ctx.held || !insideCrop(o, ctx.perception)) continue;
    LeftRecord l;
    l.object = o.index;
    l.position = o.T_world_object.translation();
    double up = 0;
    for (int a = 0; a < 3; ++a) up = std::max(up, std::abs(o.T_world_object.linear()(2, a)));
    l.tilt = std::acos(std::min(1.0, up));
    const auto why = ctx.why_not.find(o.index);
    l.reason = why != ctx.why_not.end() ? why->second : "not tried";
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
