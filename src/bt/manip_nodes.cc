// The manipulation node library in one file on purpose (about 600 lines): each node is a short
// class over the task layer's actions, and the file reads as the catalogue `minimanip nodes-doc`
// prints, in its order.
#include "bt/manip_nodes.h"

#include <algorithm>
#include <memory>
#include <sstream>

#include "bt/factory.h"
#include "sim/hardware.h"
#include "task/pick_place.h"

namespace mm::bt {

template <>
TypeInfo typeInfo<Pose>() {
  return {"Pose", [](const std::string& s) {
            std::vector<double> v;
            std::stringstream in(s);
            for (std::string item; std::getline(in, item, ';');) v.push_back(parseReal(item));
            if (v.size() != 3 && v.size() != 7)
              throw RuntimeError("a pose is written \"x;y;z\" or \"x;y;z;qw;qx;qy;qz\" [m], got \"" + s + "\"");
            Quat q = Quat::Identity();
            if (v.size() == 7) {
              q = Quat(v[3], v[4], v[5], v[6]);
              if (q.norm() < 1e-9) throw RuntimeError("a zero quaternion in \"" + s + "\"");
              q.normalize();
            }
            return Any::other(makePose(Vec3(v[0], v[1], v[2]), q.toRotationMatrix()), "Pose");
          }};
}
template <>
TypeInfo typeInfo<GraspList>() {
  return {"GraspList", {}};
}
template <>
TypeInfo typeInfo<GraspSolution>() {
  return {"Grasp", {}};
}
template <>
TypeInfo typeInfo<PlanningScene>() {
  return {"PlanningScene", {}};
}

namespace {

// ---- actions that move the arm ---------------------------------------------------------------

// Plans when it starts (no simulated time), then RUNNING while the executor moves the arm; a
// halt brings the arm to a controlled stop. If a halted motion is still braking when it starts,
// it waits for the arm to come to rest before planning from where it stopped.
class MotionAction : public StatefulActionNode {
 public:
  MotionAction(const std::string& name, const NodeConfig& config, TaskNodeEnv& env)
      : StatefulActionNode(name, config), env_(env) {}

 protected:
  /// The motion from where the arm rests; a failure is recorded by the planning function.
  virtual Failure plan(TrialContext& ctx, Plan& out) = 0;
  /// Called when the plan or its execution failed (the failure already recorded).
  virtual void failed(TrialContext&) {}
  TrialContext& ctx() const { return *env_.ctx; }

  NodeStatus onStart() final {
    ctx().actionStarted();
    if (ctx().executor.busy()) {
      waiting_ = true;
      return NodeStatus::kRunning;
    }
    return begin();
  }
  NodeStatus onRunning() final {
    if (waiting_) {
      if (ctx().executor.busy()) return NodeStatus::kRunning;
      waiting_ = false;
      return begin();
    }
    if (!ticket_->done) return NodeStatus::kRunning;
    if (ticket_->result.ok()) return NodeStatus::kSuccess;
    failed(ctx());
    return NodeStatus::kFailure;
  }
  void onHalted() final {
    if (!waiting_ && ticket_ && !ticket_->done) ctx().executor.halt();
    waiting_ = false;
  }

  TaskNodeEnv& env_;

 private:
  struct Ticket {
    bool done = false;
    Failure result;
  };
  NodeStatus begin() {
    TrialContext& c = ctx();
    Plan p;
    if (!plan(c, p).ok()) {
      failed(c);
      return NodeStatus::kFailure;
    }
    if (p.steps.empty()) {  // already there
      c.q_rest = p.q_end;
      return NodeStatus::kSuccess;
    }
    ticket_ = std::make_shared<Ticket>();
    c.executor.start(executePlan(c, std::move(p)), [&c, t = ticket_](Motion& m) {
      t->result = finishExecution(c, m);
      t->done = true;
    });
    return NodeStatus::kRunning;
  }
  bool waiting_ = false;
  std::shared_ptr<Ticket> ticket_;
};

class PlanAndExecutePick final : public MotionAction {
 public:
  using MotionAction::MotionAction;
  static PortsList providedPorts() { return {inputPort<Pose>("object_pose", "the detected object to pick (DetectObject's output)")}; }

 protected:
  Failure plan(TrialContext& c, Plan& out) override {
    const Pose pose = getInput<Pose>("object_pose").value();
    const int i = perceivedObjectAt(c, pose);
    if (i < 0) return c.fail({"grasp_pose_ik", FailureKind::kPrecondition, "no detected object within 5 cm of object_pose"});
    const ObjectState object = c.objects[i];
    GraspSolution g;
    if (const Failure f = selectGrasp(c, object, graspCandidates(c, object), 0, g); !f.ok()) return c.fail(f);
    return planPick(c, g, out);
  }
};

class PushObject final : public MotionAction {
 public:
  using MotionAction::MotionAction;
  static PortsList providedPorts() { return {inputPort<Pose>("object_pose", "the detected object to push (DetectObject's output)")}; }

 protected:
  Failure plan(TrialContext& c, Plan& out) override {
    const int i = perceivedObjectAt(c, getInput<Pose>("object_pose").value());
    if (i < 0) return c.fail({"plan_push", FailureKind::kPrecondition, "no detected object within 5 cm of object_pose"});
    return planPush(c, c.objects[i], out);
  }
};

class PlanAndExecutePlace final : public MotionAction {
 public:
  using MotionAction::MotionAction;
  static PortsList providedPorts() { return {inputPort<Pose>("place_pose", "where the held object should rest")}; }

 protected:
  Failure plan(TrialContext& c, Plan& out) override {
    return planPlace(c, getInput<Pose>("place_pose").value(), true, out);
  }
  // A place of the object still in the hand failed there: ComputePlacePosition's next_free passes it by.
  void failed(TrialContext& c) override {
    if (c.held >= 0) c.place_failed.push_back(getInput<Pose>("place_pose").value().translation());
  }
};

class MoveToHome final : public MotionAction {
 public:
  using MotionAction::MotionAction;
  static PortsList providedPorts() { return {}; }

 protected:
  Failure plan(TrialContext& c, Plan& out) override { return planHome(c, out); }
};

class MoveToSafe final : public MotionAction {
 public:
  using MotionAction::MotionAction;
  static PortsList providedPorts() { return {}; }

 protected:
  Failure plan(TrialContext& c, Plan& out) override { return planRetreatUp(c, c.options.retreat_distance, out); }
};

class OpenGripper final : public MotionAction {
 public:
  using MotionAction::MotionAction;
  static PortsList providedPorts() { return {}; }

 protected:
  Failure plan(TrialContext& c, Plan& out) override {
    out = gripperPlan(c, c.robot.spec().gripper.travel, "open_gripper");
    return {};
  }
};

class CloseGripper final : public MotionAction {
 public:
  using MotionAction::MotionAction;
  static PortsList providedPorts() { return {}; }

 protected:
  Failure plan(TrialContext& c, Plan& out) override {
    out = gripperPlan(c, 0.0, "close_gripper");
    return {};
  }
};

class ExecuteMTCPlan final : public MotionAction {
 public:
  using MotionAction::MotionAction;
  static PortsList providedPorts() { return {}; }

 protected:
  Failure plan(TrialContext& c, Plan& out) override {
    if (!c.plan) {
      c.stage("execute_plan");
      return c.fail({"execute_plan", FailureKind::kPrecondition, "no plan to execute (PlanMTCPick or PlanMTCPlace first)"});
    }
    if (c.plan->name == "pick") {
      double open = 0;
      for (const PlanStep& s : c.plan->steps) open = std::max(open, s.opening);
      c.last_grasp = TrialContext::ChosenGrasp{c.plan->T_world_grasp, open};
    }
    out = std::move(*c.plan);
    c.plan.reset();
    return {};
  }
};

// ---- synchronous actions ---------------------------------------------------------------------

class TaskAction : public SyncActionNode {
 public:
  TaskAction(const std::string& name, const NodeConfig& config, TaskNodeEnv& env) : SyncActionNode(name, config), env_(env) {}

 protected:
  NodeStatus tick() final {
    ctx().actionStarted();
    return run(ctx());
  }
  virtual NodeStatus run(TrialContext& c) = 0;
  TrialContext& ctx() const { return *env_.ctx; }
  void output(const std::string& port, const Any& v) {
    if (const auto err = setOutput(port, v)) throw RuntimeError(*err);
  }
  TaskNodeEnv& env_;
};

NodeStatus statusOf(const Failure& f) { return f.ok() ? NodeStatus::kSuccess : NodeStatus::kFailure; }

class DetectObject final : public TaskAction {
 public:
  using TaskAction::TaskAction;
  static PortsList providedPorts() {
    return {inputPort<std::string>("object_name", "target_cube",
                                   "an object of the scene (object_3) or any other name for the most accessible detected one"),
            outputPort<Pose>("object_pose", "its perceived pose in the world frame")};
  }

 protected:
  NodeStatus run(TrialContext& c) override {
    if (!detectObjects(c).ok()) return NodeStatus::kFailure;
    const std::string name = getInput<std::string>("object_name").value();
    int i = -1;
    for (size_t k = 0; k < c.objects.size(); ++k)
      if (c.objects[k].name == name) i = static_cast<int>(k);
    if (i < 0) i = mostAccessibleObject(c);
    if (i < 0) return statusOf(c.fail({"perception", FailureKind::kPerception, "no object left to pick in the bin"}));
    output("object_pose", toAny(c.objects[i].T_world_object));
    return NodeStatus::kSuccess;
  }
};

class RegisterCamera final : public TaskAction {
 public:
  using TaskAction::TaskAction;
  static PortsList providedPorts() { return {}; }

 protected:
  NodeStatus run(TrialContext& c) override { return statusOf(registerCamera(c)); }
};

class TriggerPointCloud final : public TaskAction {
 public:
  using TaskAction::TaskAction;
  static PortsList providedPorts() { return {}; }

 protected:
  NodeStatus run(TrialContext& c) override { return statusOf(detectObjects(c)); }
};

class WaitForGraspCandidates final : public TaskAction {
 public:
  using TaskAction::TaskAction;
  static PortsList providedPorts() {
    return {inputPort<unsigned>("timeout", "3000", "[ms] accepted; the candidates are ready at once"),
            inputPort<std::string>("source", "",
                                   "model: from each perceived object's shape and pose; cloud: model-free, from the perception "
                                   "camera's points, each under the perceived object it closes on; external: from the external "
                                   "component (external.command) given the same view, likewise; empty: the experiment's grasp.source"),
            outputPort<GraspList>("candidates", "grasp candidates, most accessible object first, best first per object")};
  }

 protected:
  NodeStatus run(TrialContext& c) override {
    const auto source_in = getInput<std::string>("source");
    const std::string source = source_in ? source_in.value() : "";
    if (source != "" && source != "model" && source != "cloud" && source != "external")
      throw RuntimeError("WaitForGraspCandidates: source '" + source + "': expected model, cloud, external or nothing");
    const bool external = source == "external" || (source.empty() && c.options.grasp_source == TaskOptions::GraspSource::kExternal);
    if (external || source == "cloud" || (source.empty() && c.options.grasp_source == TaskOptions::GraspSource::kCloud)) {
      // Objects in the order of their best candidate from the camera's points (or the component's).
      std::vector<std::pair<ObjectState, std::vector<GraspCandidate>>> per_object;
      const Failure f = external ? externalGraspCandidates(c, per_object) : cloudGraspCandidates(c, per_object);
      if (!f.ok()) return statusOf(c.fail(f));
      GraspList list;
      for (const auto& [object, candidates] : per_object)
        for (size_t k = 0; k < candidates.size() && k < static_cast<size_t>(c.options.max_grasp_candidates); ++k)
          list.push_back({object, candidates[k]});
      output("candidates", toAny(list));
      return NodeStatus::kSuccess;
    }
    // Objects by accessibility: those with a grasp that passes every check first, each group by
    // the room around them.
    std::vector<const ObjectState*> order, later;
    for (int i : objectsByRoom(c)) (graspable(c, c.objects[i]) ? order : later).push_back(&c.objects[i]);
    order.insert(order.end(), later.begin(), later.end());
    GraspList list;
    for (const ObjectState* object : order) {
      const auto candidates = graspCandidates(c, *object);
      for (size_t k = 0; k < candidates.size() && k < static_cast<size_t>(c.options.max_grasp_candidates); ++k)
        list.push_back({*object, candidates[k]});
    }
    if (list.empty()) {
      c.stage("grasp_candidates");
      return statusOf(c.fail({"grasp_candidates", FailureKind::kNoGrasp,
                              order.empty() ? "no object detected (TriggerPointCloud first)" : "no grasp candidate for any detected object"}));
    }
    output("candidates", toAny(list));
    return NodeStatus::kSuccess;
  }
};

// The first candidate from position `first` on that passes the filters (IK, collision, approach
// and lift), object by object.
NodeStatus selectFromList(TrialContext& c, const GraspList& list, size_t first, GraspSolution& out) {
  Failure last{"grasp_pose_ik", FailureKind::kNoGrasp, "no grasp candidate left in the list"};
  for (size_t k = first; k < list.size();) {
    std::vector<GraspCandidate> same_object;
    const ObjectState& object = list[k].object;
    size_t j = k;
    for (; j < list.size() && list[j].object.index == object.index; ++j) same_object.push_back(list[j].candidate);
    last = selectGrasp(c, object, same_object, 0, out);
    if (last.ok()) return NodeStatus::kSuccess;
    k = j;
  }
  return statusOf(c.fail(last));
}

class SelectBestGrasp final : public TaskAction {
 public:
  using TaskAction::TaskAction;
  static PortsList providedPorts() {
    return {inputPort<GraspList>("candidates", "WaitForGraspCandidates' list"),
            outputPort<GraspSolution>("selected", "the first candidate that passes IK, collision and approach checks"),
            outputPort<PlanningScene>("planning_scene", "the scene it was checked against")};
  }

 protected:
  NodeStatus run(TrialContext& c) override {
    GraspSolution g;
    const NodeStatus s = selectFromList(c, getInput<GraspList>("candidates").value(), 0, g);
    if (s == NodeStatus::kSuccess) {
      output("selected", toAny(g));
      if (config().output_ports.count("planning_scene")) {
        PlanningScene scene;
        scene.obstacles = c.statics;
        output("planning_scene", toAny(scene));
      }
    }
    return s;
  }
};

class SelectNextGrasp final : public TaskAction {
 public:
  using TaskAction::TaskAction;
  static PortsList providedPorts() {
    return {inputPort<GraspList>("candidates", "WaitForGraspCandidates' list"),
            inputPort<int>("index", "1", "list position to start from; grasps that failed in this trial are skipped"),
            outputPort<GraspSolution>("selected", "the next candidate that passes IK, collision and approach checks")};
  }

 protected:
  NodeStatus run(TrialContext& c) override {
    GraspSolution g;
    const int index = std::max(0, getInput<int>("index").value());
    const NodeStatus s = selectFromList(c, getInput<GraspList>("candidates").value(), static_cast<size_t>(index), g);
    if (s == NodeStatus::kSuccess) output("selected", toAny(g));
    return s;
  }
};

// Planning that starts from where the arm rests: while a halted motion still brakes, it waits
// (RUNNING) for the arm to come to rest, then plans (no simulated time).
class PlanningAction : public StatefulActionNode {
 public:
  PlanningAction(const std::string& name, const NodeConfig& config, TaskNodeEnv& env)
      : StatefulActionNode(name, config), env_(env) {}

 protected:
  virtual NodeStatus run(TrialContext& c) = 0;
  NodeStatus onStart() final {
    env_.ctx->actionStarted();
    return onRunning();
  }
  NodeStatus onRunning() final { return env_.ctx->executor.busy() ? NodeStatus::kRunning : run(*env_.ctx); }
  void onHalted() final {}
  TaskNodeEnv& env_;
};

class PlanMTCPick final : public PlanningAction {
 public:
  using PlanningAction::PlanningAction;
  static PortsList providedPorts() {
    return {inputPort<GraspSolution>("grasp_pose", "a selected grasp (SelectBestGrasp, SelectNextGrasp)"),
            inputPort<double>("approach_dist", "0.10", "[m] pre-grasp height above the grasp")};
  }

 protected:
  NodeStatus run(TrialContext& c) override {
    GraspSolution g = getInput<GraspSolution>("grasp_pose").value();
    const double approach = getInput<double>("approach_dist").value();
    if (std::abs(approach - g.approach_distance) > 1e-9) {
      GraspSolution again;
      const Failure f = selectGrasp(c, g.object, {g.candidate}, 0, again, approach);
      if (!f.ok()) return c.fail(f), NodeStatus::kFailure;
      g = again;
    }
    Plan p;
    if (!planPick(c, g, p).ok()) return NodeStatus::kFailure;
    c.plan = std::move(p);
    return NodeStatus::kSuccess;
  }
};

class PlanMTCPlace final : public PlanningAction {
 public:
  using PlanningAction::PlanningAction;
  static PortsList providedPorts() { return {inputPort<Pose>("place_pose", "where the held object should rest")}; }

 protected:
  NodeStatus run(TrialContext& c) override {
    Plan p;
    if (!planPlace(c, getInput<Pose>("place_pose").value(), false, p).ok()) return NodeStatus::kFailure;
    c.plan = std::move(p);
    return NodeStatus::kSuccess;
  }
};

class VerifyGraspForce final : public TaskAction {
 public:
  using TaskAction::TaskAction;
  static PortsList providedPorts() {
    return {inputPort<double>("min_force", "2.0", "[N] per finger"),
            // Untyped, as the source's tree needs: its Precondition reads {ok} through a string port,
            // and BT.CPP refuses to build a tree where one key has two different declared types.
            outputPort<AnyTypeAllowed>("result", "true when an object is held with at least min_force")};
  }

 protected:
  NodeStatus run(TrialContext& c) override {
    const double min_force = getInput<double>("min_force").value();
    const bool ok = c.held >= 0 && c.hw.gripperForce() >= min_force && c.hw.gripperOpening() >= kEmptyGrip;
    output("result", Any(ok));
    return NodeStatus::kSuccess;
  }
};

class ComputePlacePosition final : public TaskAction {
 public:
  using TaskAction::TaskAction;
  static PortsList providedPorts() {
    return {optionalInputPort<int>("pick_count", "objects placed so far: the slot to fill (asked unless next_free)"),
            inputPort<bool>("next_free", "false",
                            "the nearest slot that nothing was placed at and no place of the object held failed at in this "
                            "trial, pick_count not read (every free slot failed at: the one failed at least)"),
            outputPort<Pose>("place_pose", "the slot's pose (row by row in the place grid)")};
  }

 protected:
  NodeStatus run(TrialContext& c) override {
    const int rows = c.options.place_rows, cols = c.options.place_columns;
    const std::vector<Vec3> cells = placeGridOffsets(c.options);
    Pose T = env_.T_world_place_target;
    int k = -1;
    if (getInput<bool>("next_free").value()) {
      // What the robot knows of the tray: where it released objects over their targets, and where a
      // place of the object still held failed (a neighbour in the way, the slot out of reach).
      std::vector<Vec3> slots, placed;
      for (const Vec3& offset : cells) slots.push_back(T.translation() + offset);
      for (const PickRecord& p : c.out.picks)
        if (p.at_target) placed.push_back(p.T_world_target.translation());
      k = nextFreeSlot(slots, placed, c.place_failed, c.options.place_pitch);
      if (k < 0) {
        c.stage("place_slot");
        return statusOf(c.fail({"place_slot", FailureKind::kPrecondition,
                                "the place area is full (" + std::to_string(rows * cols) + " slots, each with an object placed)"}));
      }
    } else {
      const auto count = getInput<int>("pick_count");
      if (!count) {
        c.stage("place_slot");
        return statusOf(c.fail({"place_slot", FailureKind::kPrecondition, "no pick_count given, and next_free not set"}));
      }
      k = *count;
      if (k < 0 || k >= rows * cols) {
        c.stage("place_slot");
        return statusOf(c.fail({"place_slot", FailureKind::kPrecondition,
                                "the place area is full (" + std::to_string(rows * cols) + " slots), slot " + std::to_string(k) + " asked"}));
      }
    }
    T.translation() += cells[static_cast<size_t>(k)];
    c.place_slots.push_back(T.translation());
    output("place_pose", toAny(T));
    return NodeStatus::kSuccess;
  }
};

class IncrementCounter final : public TaskAction {
 public:
  using TaskAction::TaskAction;
  static PortsList providedPorts() { return {bidirectionalPort<int>("key", "the counter (an empty entry counts from 0)")}; }

 protected:
  NodeStatus run(TrialContext&) override {
    const auto v = getInput<int>("key");
    output("key", Any((v ? *v : 0) + 1));
    return NodeStatus::kSuccess;
  }
};

class ReportCompletion final : public TaskAction {
 public:
  using TaskAction::TaskAction;
  static PortsList providedPorts() { return {inputPort<int>("total", "objects placed")}; }

 protected:
  NodeStatus run(TrialContext& c) override {
    c.out.reported_total = getInput<int>("total").value();
    return NodeStatus::kSuccess;
  }
};

// ---- conditions ------------------------------------------------------------------------------

class TaskCondition : public ConditionNode {
 public:
  TaskCondition(const std::string& name, const NodeConfig& config, TaskNodeEnv& env) : ConditionNode(name, config), env_(env) {}

 protected:
  TrialContext& ctx() const { return *env_.ctx; }
  TaskNodeEnv& env_;
};

class IsSystemHealthy final : public TaskCondition {
 public:
  using TaskCondition::TaskCondition;
  static PortsList providedPorts() {
    return {inputPort<double>("max_tracking_error", "0.05", "[rad] largest joint error to the commanded position")};
  }

 protected:
  NodeStatus tick() override {
    const Hardware& hw = ctx().hw;
    const double limit = getInput<double>("max_tracking_error").value();
    const double error = (hw.commandedPositions() - hw.jointPositions()).cwiseAbs().maxCoeff();
    return !hw.unstable() && hw.collisionEvents() == 0 && error <= limit ? NodeStatus::kSuccess : NodeStatus::kFailure;
  }
};

class IsBinNotEmpty final : public TaskCondition {
 public:
  using TaskCondition::TaskCondition;
  static PortsList providedPorts() {
    return {inputPort<bool>("count_held", "true",
                            "the object in the hand counts (from the fingers closing on it to their letting go); false: the bin's sensor alone")};
  }

 protected:
  NodeStatus tick() override {
    const bool held = ctx().held >= 0 && getInput<bool>("count_held").value();
    return held || objectsInBin(ctx()) > 0 ? NodeStatus::kSuccess : NodeStatus::kFailure;
  }
};

class IsGraspable final : public TaskCondition {
 public:
  using TaskCondition::TaskCondition;
  static PortsList providedPorts() { return {inputPort<Pose>("object_pose", "a detected object (DetectObject's output)")}; }

 protected:
  NodeStatus tick() override {
    const int i = perceivedObjectAt(ctx(), getInput<Pose>("object_pose").value());
    return i >= 0 && graspable(ctx(), ctx().objects[i]) ? NodeStatus::kSuccess : NodeStatus::kFailure;
  }
};

class IsLessThan final : public TaskCondition {
 public:
  using TaskCondition::TaskCondition;
  static PortsList providedPorts() { return {inputPort<int>("key_A", "left side"), inputPort<int>("key_B", "right side")}; }

 protected:
  NodeStatus tick() override {
    return getInput<int>("key_A").value() < getInput<int>("key_B").value() ? NodeStatus::kSuccess : NodeStatus::kFailure;
  }
};

template <class T>
void add(Factory& f, TaskNodeEnv& env, const std::string& id, const std::string& description) {
  NodeManifest m;
  m.id = id;
  m.kind = std::is_base_of_v<ConditionNode, T> ? NodeKind::kCondition : NodeKind::kAction;
  m.ports = T::providedPorts();
  m.description = description;
  m.build = [&env](const std::string& name, const NodeConfig& config) { return std::make_unique<T>(name, config, env); };
  f.registerNode(std::move(m));
}

}  // namespace

void registerTaskNodes(Factory& f, TaskNodeEnv& env) {
  add<DetectObject>(f, env, "DetectObject",
                    "Perceives the bin (the configured perception mode) and outputs the pose of the object named, or of the "
                    "most accessible one: the first by room to its neighbours that has a grasp passing every check (IK, collision, "
                    "approach, lift), else the first by room. FAILURE when nothing is detected.");
  add<RegisterCamera>(f, env, "RegisterCamera",
                      "Camera mode: registers the camera against the cell's static boxes (table, bin, tray) in a fresh depth "
                      "frame, and perception uses that pose from then on (a camera knocked off its mount). FAILURE when the "
                      "cell's surfaces do not pin the camera down or fit poorly. SUCCESS with nothing done in the other "
                      "perception modes.");
  add<PlanAndExecutePick>(f, env, "PlanAndExecutePick",
                          "Plans the pick of the detected object at object_pose (grasp candidates filtered by IK, collision, "
                          "approach and lift; path to the pre-grasp) and executes it: open, move, approach, close, attach, lift. "
                          "RUNNING while the arm moves; FAILURE with the stage and reason (also when the fingers close on "
                          "nothing or the object drops).");
  add<PlanAndExecutePlace>(f, env, "PlanAndExecutePlace",
                           "Plans and executes the place of the held object so it rests at place_pose: move above it, lower, "
                           "open, detach, retreat. FAILURE when nothing is held or no place pose is reachable.");
  add<MoveToHome>(f, env, "MoveToHome",
                  "Plans and executes a collision-free move to the home configuration (with a held object attached); from a "
                  "start the planner refuses (within the padding of an obstacle, or inside an object the hand pushed), the "
                  "hand first leaves straight up as MoveToSafe does.");
  add<MoveToSafe>(f, env, "MoveToSafe",
                  "A straight move of the TCP up by motion.retreat_distance from where it is; from inside a static part of "
                  "the cell (a finger left in a wall), first a short horizontal move out of it, the way it leaves soonest.");
  add<OpenGripper>(f, env, "OpenGripper",
                   "Opens the gripper fully, or, where open fingers would come within 3 mm of a part of the cell (a bin's wall "
                   "beside a hand stopped in the bin), as far as keeps them 3 mm from it; a held object is let go of (placed, if "
                   "a place plan brought it over its target).");
  add<CloseGripper>(f, env, "CloseGripper",
                    "Closes the gripper with the grasp force; a detected object left between the fingers becomes the held one.");
  add<IsSystemHealthy>(f, env, "IsSystemHealthy",
                       "SUCCESS while the simulation is stable, no collision event has happened and every joint is within "
                       "max_tracking_error of its command.");
  add<IsBinNotEmpty>(f, env, "IsBinNotEmpty",
                     "SUCCESS while objects remain to be cleared from the bin: one rests in it as the bin's sensor sees it "
                     "(over the bin floor, less than 10 cm above it) or, with count_held, the gripper holds one (from the "
                     "fingers closing on it to their letting go), so that the pick and place of the last object do not fail "
                     "a condition checked during them; it fails once the last object is let go of. With count_held false, "
                     "the bin's sensor alone.");
  add<IsGraspable>(f, env, "IsGraspable",
                   "SUCCESS when the detected object at object_pose has a grasp that passes every check now (IK, collision, "
                   "approach, lift); FAILURE otherwise (flush against a neighbour or a wall: PushObject it).");
  add<PushObject>(f, env, "PushObject",
                  "Pushes the detected object at object_pose (else the next object by room that can be) motion.push_distance "
                  "with the closed fingers: down beside it, along a face normal towards room inside the walls (a neighbour "
                  "in the way is pushed along if it has room), up; where the fingers have no room beside it and "
                  "motion.drag_depth is set, it is dragged by its top instead (fingertips pressed into its upper face); "
                  "at a high joint impedance. RUNNING while the "
                  "arm moves; FAILURE when no direction has room. Perceive again afterwards: the object has moved.");
  add<IsLessThan>(f, env, "IsLessThan", "SUCCESS when key_A < key_B (integers).");
  add<TriggerPointCloud>(f, env, "TriggerPointCloud", "Perceives the bin (as DetectObject, without choosing an object).");
  add<WaitForGraspCandidates>(f, env, "WaitForGraspCandidates",
                              "Grasp candidates for the perceived objects: objects with a grasp that passes every check first, "
                              "each group by room to its neighbours, each object's candidates "
                              "by score (up to grasp.max_candidates each). With source cloud (or grasp.source: cloud): "
                              "model-free candidates from a fresh view of the perception camera, each under the perceived "
                              "object its pads close on, objects in the order of their best candidate (after a pick that failed, those within 3 cm "
                              "of its grasp last). FAILURE when there is none.");
  add<SelectBestGrasp>(f, env, "SelectBestGrasp",
                       "The first candidate that passes the source's filterGrasps (pre-grasp IK, no collision, straight "
                       "approach and lift). FAILURE when none does.");
  add<SelectNextGrasp>(f, env, "SelectNextGrasp",
                       "As SelectBestGrasp from list position index on, skipping grasps whose execution failed in this trial.");
  add<PlanMTCPick>(f, env, "PlanMTCPick",
                   "Plans the pick of the selected grasp (open, connect, approach of approach_dist, close, attach, lift) "
                   "as the current plan.");
  add<PlanMTCPlace>(f, env, "PlanMTCPlace", "Plans the place of the held object at place_pose (connect, lower) as the current plan.");
  add<ExecuteMTCPlan>(f, env, "ExecuteMTCPlan", "Executes the current plan; RUNNING while the arm moves.");
  add<VerifyGraspForce>(f, env, "VerifyGraspForce",
                        "Writes result: an object is held, the fingers stopped on it (>= 1 mm open each) and press with at least "
                        "min_force. Always SUCCESS.");
  add<ComputePlacePosition>(f, env, "ComputePlacePosition",
                            "The pose of slot pick_count in the place grid (place.rows x place.columns at place.pitch, centred "
                            "on the scene's place target; slots nearest the centre first, then row by row); with next_free, of "
                            "the first slot with no object released over it and no failed place of the held object. FAILURE when "
                            "the grid is full.");
  add<IncrementCounter>(f, env, "IncrementCounter", "key += 1.");
  add<ReportCompletion>(f, env, "ReportCompletion", "Records total as the trial's reported count.");
}

}  // namespace mm::bt
