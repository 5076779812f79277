#include "task/pick_place.h"

#include <chrono>
#include <cmath>
#include <optional>

#include "core/rng.h"
#include "sim/controllers.h"
#include "planning/chomp.h"
#include "planning/time_parameterization.h"
#include "sim/hardware.h"

namespace mm {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kSupportTolerance = 0.003;  // [m] held object may touch its support this much
constexpr double kLimitMargin = 0.05;        // [rad] grasp and place solutions keep off the limits
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

Obstacle boxOf(const ObjectState& o) {
  Obstacle b;
  b.type = Obstacle::Type::kBox;
  b.size = o.half_size;
  b.T_world = o.T_world_object;
  b.name = o.name;
  return b;
}

// Angle between two box orientations, modulo the box's symmetry about its vertical axis.
double symmetricAngle(const Mat3& A, const Mat3& B, int fold) {
  double best = INFINITY;
  for (int k = 0; k < fold; ++k) best = std::min(best, angleBetween(A, B * rotZ(2 * M_PI * k / fold)));
  return best;
}

int yawSymmetry(const Vec3& half) { return std::abs(half.x() - half.y()) < 1e-6 ? 4 : 2; }

class Trial {
 public:
  Trial(Hardware& hw, const RobotModel& robot, const std::vector<Obstacle>& statics, const PlaceTarget& target,
        const TaskOptions& o, const PerceptionOptions& po, uint64_t seed, uint64_t trial)
      : hw_(hw), robot_(robot), statics_(statics), target_(target), o_(o), po_(po),
        rng_perception_(Rng::stream(seed, trial, Purpose::kPerception)),
        rng_ik_(Rng::stream(seed, trial, Purpose::kIk)),
        rng_plan_(Rng::stream(seed, trial, Purpose::kPlanner)),
        ik_(makeIkSolver(o.ik_solver, robot)), ik_near_(makeIkSolver("dls", robot)) {}

  TrialOutcome run() {
    if (!pick()) return finish();
    if (!place()) return finish();
    if (!home()) return finish();
    evaluate();
    return finish();
  }

 private:
  // ---- bookkeeping --------------------------------------------------------------------------
  bool fail(const std::string& stage, const std::string& reason) {
    out_.success = false;
    out_.failure_stage = stage;
    out_.failure_reason = reason;
    if (reason.rfind("SIM_UNSTABLE", 0) == 0) out_.sim_unstable = true;
    if (!out_.stages.empty()) out_.stages.back().ok = false;
    return false;
  }
  StageRecord& stage(const std::string& name) {
    out_.stages.push_back({name, true, 0, 0});
    return out_.stages.back();
  }
  TrialOutcome finish() {
    out_.collision_count = hw_.collisionEvents();
    out_.collision_log = hw_.collisionLog();
    out_.sim_time = hw_.time() - t_sim0_;
    out_.compute_time = out_.perception_time + out_.plan_pick_time + out_.plan_place_time + home_compute_;
    out_.total_time = out_.perception_time + out_.plan_pick_time + out_.execute_pick_time + out_.plan_place_time +
                      out_.execute_place_time + out_.return_home_time;
    return out_;
  }
  IkFunction ikNear() {
    return [this](const Pose& T, const VecX& seed, VecX& q) {
      IkRequest one = o_.ik;
      one.target = T;
      one.seed = seed;
      one.max_attempts = 1;  // a single descent from the seed: stay on its branch
      one.limit_margin = 0.0;
      // Converged far below the control period's resolution: samples 2 ms apart are differentiated
      // twice, so IK noise of 1e-5 rad would read as accelerations of several rad/s^2.
      one.tol_position = 1e-10;
      one.tol_rotation = 1e-9;
      const IkResult r = ik_near_->solve(one, rng_ik_);
      if (r.ok()) q = r.q();
      return r.ok();
    };
  }
  // The configured solver, from `seed`, kept `kLimitMargin` inside the limits.
  IkResult ikFar(const Pose& T, const VecX& seed) {
    IkRequest req = o_.ik;
    req.target = T;
    req.seed = seed;
    req.limit_margin = kLimitMargin;
    req.nearest = true;  // the least joint motion from where the arm will be
    return ik_->solve(req, rng_ik_);
  }
  PlanningScene scene(bool with_target, bool attached) const {
    PlanningScene s;
    s.obstacles = statics_;
    for (const ObjectState& ob : objects_)
      if (ob.index != target_obj_.index || with_target) s.obstacles.push_back(boxOf(ob));
    if (attached) {
      s.has_attached = true;
      s.attached_half = target_obj_.half_size;
      s.T_tcp_attached = T_tcp_object_;
      s.finger_opening = target_obj_.half_size.y();
    }
    return s;
  }
  // Executes and books the simulated time; `monitor` watches for drops while holding.
  bool execute(const std::string& name, const JointTrajectory& t, double grip, double force, bool holding,
               double& bucket) {
    StageRecord& st = stage(name);
    StepMonitor monitor;
    if (holding) monitor = [this] { return dropCheck(); };
    const ExecutionResult r = executeTrajectory(hw_, t, grip, force, monitor);
    st.sim_seconds = r.duration;
    bucket += r.duration;
    out_.max_tracking_error = std::max(out_.max_tracking_error, r.max_tracking_error);
    if (!r.ok) {
      if (r.reason.rfind("dropped", 0) == 0) out_.dropped = true;
      return fail(name, r.reason);
    }
    return true;
  }
  std::string dropCheck() {
    const Pose T_tcp_obj = hw_.tcpPose().inverse() * hw_.object(target_obj_.index).T_world_object;
    const double d = (T_tcp_obj.translation() - T_tcp_object_actual_.translation()).norm();
    if (d > o_.drop_distance)
      return "dropped: object " + std::to_string(int(d * 1000)) + " mm from its in-hand pose";
    return "";
  }
  uint64_t planSeed() { return rng_plan_.next(); }
  // The optional optimizer after the planner (CHOMP); its time counts as planning time.
  void optimize(PlanResult& r, const PlanningScene& scene, CollisionChecker& checker) const {
    if (o_.optimizer != "chomp" || !r.ok) return;
    r.path = chompSmooth(robot_, scene, checker, r.path).path;
  }
  // `checker` is the one that validated `path`: it also judges the samples of methods that leave
  // the straight segments (jerk_limited through waypoints, TOTG's blends), which back off where one
  // is invalid.
  JointTrajectory timeParameterize(const std::vector<VecX>& path, CollisionChecker& checker, std::string& failure) const {
    TimedPath t = mm::timeParameterize(o_.time_parameterization, path, robot_, o_.scaling, hw_.period(),
                                       [&](const VecX& q) { return checker.isValid(q); });
    failure = t.failure;
    return std::move(t.trajectory);
  }

  // ---- pick -----------------------------------------------------------------------------------
  bool pick() {
    t_sim0_ = hw_.time();
    const VecX q0 = hw_.jointPositions();  // CurrentState
    {
      StageRecord& st = stage("perception");
      const auto t = Clock::now();
      const PerceptionResult p = perceive(hw_.objects(), po_, rng_perception_);
      st.compute_seconds = out_.perception_time = since(t);
      if (!p.ok) return fail("perception", p.reason);
      objects_ = p.objects;
    }
    out_.objects_in_bin = static_cast<int>(objects_.size());
    // The target: the object with most room around it (bin-picking picks the most accessible).
    double best = -1;
    for (const ObjectState& a : objects_) {
      double room = 1.0;
      for (const ObjectState& b : objects_)
        if (a.index != b.index) room = std::min(room, (a.T_world_object.translation() - b.T_world_object.translation()).head<2>().norm());
      if (room > best) best = room, target_obj_ = a;
    }
    out_.target_object = target_obj_.index;

    const auto t_plan = Clock::now();
    StageRecord* st = &stage("grasp_pose_ik");
    std::vector<Obstacle> neighbours = statics_;
    for (const ObjectState& b : objects_)
      if (b.index != target_obj_.index) neighbours.push_back(boxOf(b));
    const double preferred_yaw = yawOf(robot_.fk(robot_.home()).linear());
    GraspOptions go = o_.grasp;
    go.max_opening = 2 * robot_.spec().gripper.travel;
    const auto candidates = topDownGrasps(target_obj_, preferred_yaw, neighbours, go);
    if (candidates.empty())
      return fail("grasp_pose_ik", "no top-down grasp for this object (tilted or too wide)");

    PlanningScene full_scene = scene(true, false), approach_scene = scene(false, false);
    const double widest = 2 * std::max(target_obj_.half_size.x(), target_obj_.half_size.y());
    full_scene.finger_opening = approach_scene.finger_opening =
        std::min(robot_.spec().gripper.travel, widest / 2 + o_.finger_margin);
    auto full = makeChecker(o_.checker, robot_, full_scene, o_.padding);
    auto no_target = makeChecker(o_.checker, robot_, approach_scene, o_.padding);
    std::string last_stage = "grasp_pose_ik", last_reason;
    bool found = false;
    for (size_t c = 0; c < candidates.size() && c < static_cast<size_t>(o_.max_grasp_candidates); ++c) {
      const GraspCandidate& g = candidates[c];
      ++out_.grasp_candidates_tried;
      const Pose T_grasp = g.T_world_tcp;
      Pose T_pre = T_grasp;
      T_pre.translation().z() += o_.approach_distance;
      const IkResult pre = ikFar(T_pre, robot_.home());
      if (!pre.ok()) {
        last_stage = "grasp_pose_ik", last_reason = "pre-grasp: " + pre.reason;
        continue;
      }
      if (!full->isValid(pre.q())) {
        last_stage = "grasp_pose_ik", last_reason = "pre-grasp configuration in collision (" + full->lastCollision() + ")";
        continue;
      }
      approach_ = planCartesianLine(robot_, *no_target, pre.q(), T_grasp, ikNear(), o_.cartesian);
      if (!approach_.ok) {
        last_stage = "approach", last_reason = approach_.reason;
        continue;
      }
      q_pre_ = pre.q();
      q_grasp_ = approach_.waypoints.back();
      T_grasp_ = T_grasp;
      T_tcp_object_ = T_grasp.inverse() * target_obj_.T_world_object;
      // Lift with the object attached.
      PlanningScene ls = scene(false, true);
      ls.attached_padding = -kSupportTolerance;  // the object leaves the bin floor it rests on
      auto lifting = makeChecker(o_.checker, robot_, ls, o_.padding);
      Pose T_lift = T_grasp;
      T_lift.translation().z() += o_.lift_height;
      lift_ = planCartesianLine(robot_, *lifting, q_grasp_, T_lift, ikNear(), o_.cartesian);
      out_.collision_checks += lifting->checks();
      if (!lift_.ok) {
        last_stage = "lift", last_reason = lift_.reason;
        continue;
      }
      found = true;
      out_.grasp_opening = g.width / 2;
      pre_opening_ = std::min(robot_.spec().gripper.travel, g.width / 2 + o_.finger_margin);
      break;
    }
    if (!found) {
      out_.plan_pick_time = st->compute_seconds = since(t_plan);
      out_.collision_checks += full->checks() + no_target->checks();
      return fail(last_stage, last_reason + " (after " + std::to_string(out_.grasp_candidates_tried) + " grasp candidates)");
    }
    st = &stage("connect_pregrasp");
    PlanResult connect = planJointPath(robot_, *full, q0, q_pre_, planSeed(), o_.planner);
    optimize(connect, full_scene, *full);
    out_.collision_checks += full->checks() + no_target->checks();
    out_.plan_pick_time = st->compute_seconds = since(t_plan);
    if (!connect.ok) return fail("connect_pregrasp", connect.reason);
    const double dt = hw_.period();
    std::string tp_failure;
    const JointTrajectory t_connect = timeParameterize(connect.path, *full, tp_failure);
    if (t_connect.empty()) return fail("connect_pregrasp", tp_failure);
    const JointTrajectory t_approach = cartesianTrajectory(robot_, approach_, ikNear(), o_.scaling, o_.cartesian, dt);
    const JointTrajectory t_lift = cartesianTrajectory(robot_, lift_, ikNear(), o_.scaling, o_.cartesian, dt);
    if (t_approach.empty() || t_lift.empty())
      return fail(t_approach.empty() ? "approach" : "lift", "no smooth time parameterization of the straight line");

    // Execute the pick. The fingers open to the object's half width plus a margin, not wider:
    // in a bin, the room beside the object is what limits a grasp.
    const double travel = pre_opening_;
    {
      StageRecord& s = stage("open_gripper");
      const GripperResult g = moveGripper(hw_, q0, travel, o_.grasp_force);
      s.sim_seconds = g.duration;
      out_.execute_pick_time += g.duration;
      if (!g.ok) return fail("open_gripper", g.reason);
    }
    if (!execute("move_pregrasp", t_connect, travel, o_.grasp_force, false, out_.execute_pick_time)) return false;
    if (!execute("approach", t_approach, travel, o_.grasp_force, false, out_.execute_pick_time)) return false;
    {
      StageRecord& s = stage("close_gripper");
      const GripperResult g = moveGripper(hw_, q_grasp_, 0.0, o_.grasp_force);
      s.sim_seconds = g.duration;
      out_.execute_pick_time += g.duration;
      const double expected = out_.grasp_opening;  // the object's half width across the fingers
      out_.grasp_opening = g.opening;
      if (!g.ok) return fail("close_gripper", g.reason);
      if (g.opening < 0.5 * expected || g.opening < 0.003)
        return fail("close_gripper", "nothing between the fingers (closed to " + std::to_string(g.opening * 1000) + " mm)");
    }
    stage("attach");
    T_tcp_object_actual_ = hw_.tcpPose().inverse() * hw_.object(target_obj_.index).T_world_object;
    if (o_.weld) hw_.attach(target_obj_.index, true);
    return execute("lift", t_lift, 0.0, o_.grasp_force, true, out_.execute_pick_time);
  }

  // ---- place ----------------------------------------------------------------------------------
  bool place() {
    const auto t_plan = Clock::now();
    StageRecord* st = &stage("place_pose_ik");
    const VecX q_lift = lift_.waypoints.back();
    auto carrying = makeChecker(o_.checker, robot_, scene(false, true), o_.padding);
    // Placing: the held object goes down to the tray with no padding of its own.
    PlanningScene ps = scene(false, true);
    ps.attached_padding = -kSupportTolerance;
    auto descending = makeChecker(o_.checker, robot_, ps, o_.padding);
    // TCP poses that put the object at the target, one per symmetric yaw; least wrist turn first.
    const int fold = yawSymmetry(target_obj_.half_size);
    Pose T_obj_place = target_.T_world_object;
    T_obj_place.translation().z() += o_.place_clearance;
    const double yaw_now = yawOf(robot_.fk(q_lift).linear());
    std::vector<std::pair<double, Pose>> options;
    for (int k = 0; k < fold; ++k) {
      Pose T_obj = T_obj_place;
      T_obj.linear() = T_obj_place.linear() * rotZ(2 * M_PI * k / fold);
      const Pose T_tcp = T_obj * T_tcp_object_.inverse();
      options.push_back({std::abs(wrapAngle(yawOf(T_tcp.linear()) - yaw_now)), T_tcp});
    }
    std::stable_sort(options.begin(), options.end(), [](auto& a, auto& b) { return a.first < b.first; });
    std::string last_stage = "place_pose_ik", last_reason = "no IK solution for any place pose";
    bool found = false;
    VecX q_preplace;
    for (const auto& [cost, T_place] : options) {
      Pose T_pre = T_place;
      T_pre.translation().z() += o_.approach_distance;
      const IkResult pre = ikFar(T_pre, q_lift);
      if (!pre.ok()) {
        last_stage = "place_pose_ik", last_reason = "pre-place: " + pre.reason;
        continue;
      }
      if (!carrying->isValid(pre.q())) {
        last_stage = "place_pose_ik", last_reason = "pre-place configuration in collision (" + carrying->lastCollision() + ")";
        continue;
      }
      descend_ = planCartesianLine(robot_, *descending, pre.q(), T_place, ikNear(), o_.cartesian);
      if (!descend_.ok) {
        last_stage = "place", last_reason = descend_.reason;
        continue;
      }
      // Retreat: fingers open, the placed object left behind (between the fingers, not checked).
      PlanningScene rs = scene(false, false);
      rs.finger_opening = robot_.spec().gripper.travel;
      auto retreating = makeChecker(o_.checker, robot_, rs, o_.padding);
      Pose T_up = T_place;
      T_up.translation().z() += o_.retreat_distance;
      retreat_ = planCartesianLine(robot_, *retreating, descend_.waypoints.back(), T_up, ikNear(), o_.cartesian);
      out_.collision_checks += retreating->checks();
      if (!retreat_.ok) {
        last_stage = "retreat", last_reason = retreat_.reason;
        continue;
      }
      q_preplace = pre.q();
      found = true;
      break;
    }
    if (!found) {
      out_.plan_place_time = st->compute_seconds = since(t_plan);
      return fail(last_stage, last_reason);
    }
    st = &stage("connect_place");
    PlanResult connect = planJointPath(robot_, *carrying, q_lift, q_preplace, planSeed(), o_.planner);
    optimize(connect, scene(false, true), *carrying);
    out_.collision_checks += carrying->checks() + descending->checks();
    out_.plan_place_time = st->compute_seconds = since(t_plan);
    if (!connect.ok) return fail("connect_place", connect.reason);
    const double dt = hw_.period();
    std::string tp_failure;
    const JointTrajectory t_connect = timeParameterize(connect.path, *carrying, tp_failure);
    if (t_connect.empty()) return fail("connect_place", tp_failure);
    const JointTrajectory t_descend = cartesianTrajectory(robot_, descend_, ikNear(), o_.scaling, o_.cartesian, dt);
    const JointTrajectory t_retreat = cartesianTrajectory(robot_, retreat_, ikNear(), o_.scaling, o_.cartesian, dt);
    if (t_descend.empty() || t_retreat.empty())
      return fail(t_descend.empty() ? "place" : "retreat", "no smooth time parameterization of the straight line");

    if (!execute("move_preplace", t_connect, 0.0, o_.grasp_force, true, out_.execute_place_time)) return false;
    if (!execute("place", t_descend, 0.0, o_.grasp_force, true, out_.execute_place_time)) return false;
    {
      StageRecord& s = stage("open_gripper_release");
      if (o_.weld) hw_.attach(target_obj_.index, false);  // Detach before opening, as the source's task
      const GripperResult g = moveGripper(hw_, descend_.waypoints.back(), robot_.spec().gripper.travel, o_.grasp_force);
      s.sim_seconds = g.duration;
      out_.execute_place_time += g.duration;
      if (!g.ok) return fail("open_gripper_release", g.reason);
    }
    stage("detach");
    return execute("retreat", t_retreat, robot_.spec().gripper.travel, o_.grasp_force, false, out_.execute_place_time);
  }

  // ---- home -----------------------------------------------------------------------------------
  bool home() {
    const auto t_plan = Clock::now();
    StageRecord& st = stage("plan_home");
    PlanningScene s = scene(false, false);
    ObjectState placed = target_obj_;
    placed.T_world_object = target_.T_world_object;
    s.obstacles.push_back(boxOf(placed));
    s.finger_opening = robot_.spec().gripper.travel;
    auto checker = makeChecker(o_.checker, robot_, s, o_.padding);
    PlanResult r = planJointPath(robot_, *checker, retreat_.waypoints.back(), robot_.home(), planSeed(), o_.planner);
    optimize(r, s, *checker);
    out_.collision_checks += checker->checks();
    st.compute_seconds = home_compute_ = since(t_plan);
    out_.return_home_time += home_compute_;
    if (!r.ok) return fail("plan_home", r.reason);
    std::string tp_failure;
    const JointTrajectory t = timeParameterize(r.path, *checker, tp_failure);
    if (t.empty()) return fail("plan_home", tp_failure);
    return execute("return_home", t, robot_.spec().gripper.travel, o_.grasp_force, false, out_.return_home_time);
  }

  // ---- evaluation: measured in the simulator, never assumed ------------------------------------
  void evaluate() {
    StageRecord& st = stage("evaluate");
    const VecX q = robot_.home(), zero = VecX::Zero(robot_.dof());
    const double t0 = hw_.time();
    hw_.writeGripper(robot_.spec().gripper.travel, o_.grasp_force);
    while (hw_.time() - t0 < o_.settle_time) {
      hw_.write(q, zero, zero);
      hw_.step();
      if (hw_.unstable()) {
        fail("evaluate", "SIM_UNSTABLE: " + hw_.instabilityReason());
        return;
      }
    }
    st.sim_seconds = hw_.time() - t0;
    const ObjectState o = hw_.object(target_obj_.index);
    const Vec3 p = o.T_world_object.translation(), goal = target_.T_world_object.translation();
    out_.place_position_error = (p - goal).head<2>().norm();
    out_.place_orientation_error =
        symmetricAngle(o.T_world_object.linear(), target_.T_world_object.linear(), yawSymmetry(o.half_size));
    const double rest_error = std::abs(p.z() - goal.z());
    const double speed = hw_.objectVelocity(target_obj_.index).norm();
    if (out_.place_position_error > o_.tolerance_position)
      fail("evaluate", "object " + std::to_string(out_.place_position_error * 1000) + " mm from the place target");
    else if (out_.place_orientation_error > o_.tolerance_orientation)
      fail("evaluate", "object orientation off by " + std::to_string(out_.place_orientation_error * 180 / M_PI) + " deg");
    else if (rest_error > 0.01)
      fail("evaluate", "object not resting on the target surface (height off by " + std::to_string(rest_error * 1000) + " mm)");
    else if (speed > 0.01)
      fail("evaluate", "object still moving (" + std::to_string(speed) + " m/s)");
    else
      out_.success = true;
  }

  Hardware& hw_;
  const RobotModel& robot_;
  const std::vector<Obstacle>& statics_;
  PlaceTarget target_;
  const TaskOptions& o_;
  const PerceptionOptions& po_;
  Rng rng_perception_, rng_ik_, rng_plan_;
  std::unique_ptr<IkSolver> ik_, ik_near_;
  TrialOutcome out_;
  double t_sim0_ = 0, home_compute_ = 0, pre_opening_ = 0.04;
  std::vector<ObjectState> objects_;
  ObjectState target_obj_;
  VecX q_pre_, q_grasp_;
  Pose T_grasp_ = Pose::Identity(), T_tcp_object_ = Pose::Identity(), T_tcp_object_actual_ = Pose::Identity();
  CartesianPath approach_, lift_, descend_, retreat_;
};

}  // namespace

TrialOutcome runPickAndPlace(Hardware& hw, const RobotModel& robot, const std::vector<Obstacle>& static_obstacles,
                             const PlaceTarget& target, const TaskOptions& task, const PerceptionOptions& perception,
                             uint64_t campaign_seed, uint64_t trial) {
  Trial t(hw, robot, static_obstacles, target, task, perception, campaign_seed, trial);
  return t.run();
}

}  // namespace mm
