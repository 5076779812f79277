// What the actions of one trial share: the hardware and the executor that advances it on
// simulated time, what the robot knows (perceived objects, the object in its hand, where its
// last motion ended), the current plan, and the trial's record. BT.CPP's SubTrees have isolated
// blackboards and the source's XML remaps no trial state, so this lives beside the tree; the
// values the XML names travel through ports.
#pragma once
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/failure.h"
#include "core/geometry.h"
#include "core/rng.h"
#include "grasp/grasp.h"
#include "kinematics/ik.h"
#include "perception/perception.h"
#include "planning/cartesian.h"
#include "robot/robot_model.h"
#include "sim/controllers.h"
#include "task/fault_hooks.h"
#include "task/task_options.h"
#include "task/trial_outcome.h"

namespace mm {

class ExternalComponent;
class Hardware;
class TruthScope;

/// What the campaign's camera source keeps of its last capture for scoring alone, out of the frame
/// the robot reads: the renderer's labels (known models' visible fractions) and where the camera
/// really was (a knocked camera draws from off its mount; the frame reports the mount).
struct ScoringView {
  std::vector<uint8_t> labels;  ///< SegmentLabel, width * height; empty when none were rendered
  CameraModel camera;
};

/// One step of a plan: a joint trajectory, a gripper motion, attaching the grasped object, or a
/// marker (a stage recorded without motion, as MTC's Detach).
struct PlanStep {
  enum class Kind { kTrajectory, kGripper, kAttach, kMarker };
  Kind kind = Kind::kTrajectory;
  std::string stage;            ///< recorded under this name
  JointTrajectory trajectory;   ///< kTrajectory
  JointTrajectory stop_path;    ///< kTrajectory blended into the next (ending moving): the whole of it, to brake along
  double opening = 0;           ///< [m] per finger: the gripper's goal (kGripper) or its setting during a trajectory
  VecX q_hold;                  ///< kGripper: the arm is held here
  bool holding = false;         ///< kTrajectory: watch the held object for a drop
  bool release = false;         ///< kGripper: lets go of the held object (weld off first)
  double expected_opening = -1; ///< kGripper closing on an object: its half width across the fingers [m]
  bool take_hold = false;       ///< kGripper closing: a perceived object left between the fingers becomes the held one
  bool stiff = false;           ///< kTrajectory: a contact task (a push): high joint impedance (Hardware::setStiff)
  bool guarded = false;         ///< kTrajectory: a guarded move (the place descent): contact force past the limit ends it as touch-down
};

/// What a trial's compute and execution times are booked under (the source's breakdown).
enum class TimeBucket { kPick, kPlace, kHome };

/// A planned motion (the source's MTC solution): steps executed in order, from q_start to q_end.
struct Plan {
  std::string name;  ///< "pick", "place", "home", "safe", "gripper"
  std::vector<PlanStep> steps;
  TimeBucket bucket = TimeBucket::kPick;
  VecX q_start;                            ///< where the arm must rest when it starts (as planned)
  VecX q_end;                              ///< where the arm ends (as planned)
  int object = -1;                         ///< pick: the object grasped; place: the object carried
  Vec3 object_half = Vec3::Zero();         ///< pick: its half sizes [m]
  ObjectShape object_shape = ObjectShape::kBox;  ///< pick: its shape
  std::shared_ptr<const std::vector<ConvexPiece>> object_pieces;  ///< pick: a mesh object's convex pieces
  std::string grasp_type;                  ///< pick: "top_down", "side", "cloud" or "external"
  Pose T_tcp_object = Pose::Identity();    ///< pick: the object in the hand, as planned
  Pose T_world_grasp = Pose::Identity();   ///< pick: the TCP at the grasp
  int grasp_candidates_tried = 0;
  Pose T_world_target = Pose::Identity();  ///< place: where the object will rest
  bool places = false;                     ///< place: ends with the object over its target
  double place_turn = 0;                   ///< place: [rad] that target turned about the vertical from the one asked
};

/// Advances the hardware one control period at a time with the active motion's setpoints, or
/// holds the arm where it was last sent when none is active.
class Executor {
 public:
  explicit Executor(Hardware& hw) : hw_(hw) {}
  enum class Step {
    kStepped,           ///< one period of simulated time passed
    kEnded,             ///< the active motion ended during the period
    kEndedWithoutStep,  ///< the active motion ended before using the period (no time passed)
  };
  Step step();
  /// Called before every control period (fault injection).
  void setBeforeStep(std::function<void()> f) { before_step_ = std::move(f); }
  /// Starts `m`; the arm must not be busy. The motion is owned here until the next start;
  /// `on_end` is called once when it ends (also when it ends after a halt).
  Motion& start(std::unique_ptr<Motion> m, std::function<void(Motion&)> on_end = {});
  /// A motion is running (perhaps a halted one still braking).
  bool busy() const { return active_ && active_->running(); }
  /// Controlled stop of the running motion (it keeps running until at rest).
  void halt();
  const Motion* active() const { return active_.get(); }

 private:
  void ended();
  Hardware& hw_;
  std::unique_ptr<Motion> active_;
  std::function<void(Motion&)> on_end_;
  std::function<void()> before_step_;
};

/// A grasp that passed the filters (reachable pre-grasp free of collision, straight approach and
/// lift feasible): what SelectBestGrasp chooses and PlanMTCPick plans from.
struct GraspSolution {
  ObjectState object;
  GraspCandidate candidate;
  int candidate_index = -1;   ///< position in the candidate list it came from
  int candidates_tried = 0;   ///< candidates filtered to find it
  double approach_distance = 0.1;  ///< [m] pre-grasp above the grasp
  VecX q_pre, q_grasp;
  CartesianPath approach, lift;
  Pose T_tcp_object = Pose::Identity();
  double pre_opening = 0.04;  ///< [m] per finger before the approach
  double finger_margin = 0;   ///< [m] the margin it was found with (TaskOptions finger_margin or tight_margin)
  double padding = -1;        ///< [m] the robot's padding its checks used (-1: TaskOptions padding)
};

class TrialContext {
 public:
  TrialContext(Hardware& hw, const RobotModel& robot, const std::vector<Obstacle>& statics, const TaskOptions& task,
               const PerceptionOptions& perception, uint64_t campaign_seed, uint64_t trial);
  ~TrialContext();

  Hardware& hw;
  const RobotModel& robot;
  const std::vector<Obstacle>& statics;  ///< table, bins, tray as the planner knows them
  const TaskOptions& options;
  const PerceptionOptions& perception;
  Rng rng_perception, rng_ik, rng_plan;
  Rng rng_grasp;  ///< cloud grasps' seeds
  uint64_t run_seed = 0, trial_index = 0;  ///< the campaign's seed and this trial's number
  std::unique_ptr<IkSolver> ik, ik_near;
  Executor executor;
  TrialOutcome out;
  double t_start = 0;  ///< [s] simulated time at the trial's start

  // What the robot knows. Objects go by the robot's ids for them: in the ground-truth modes the
  // simulator's indices (object_<k>); in camera mode a detection's own (kFirstDetectionId and up),
  // which nothing the robot decides relates to the simulator's.
  std::vector<ObjectState> objects;  ///< the last perception (world frame), objects not yet picked
  std::vector<int> picked;           ///< ids of objects picked (held or let go)
  int held = -1;                     ///< id of the object in the hand, -1 for none
  Pose T_tcp_held = Pose::Identity();        ///< the held object in the hand as planned
  Pose T_tcp_held_actual = Pose::Identity(); ///< as measured when the fingers closed (drop check)
  ObjectShape held_shape = ObjectShape::kBox;   ///< the held object's shape
  std::shared_ptr<const std::vector<ConvexPiece>> held_pieces;  ///< a held mesh object's convex pieces
  /// [m] the half height the place targets' centre height assumes (negative: none); an object of
  /// another height is placed that much higher or lower, so that it rests on the same surface.
  double target_half_height = -1;
  bool held_from_side = false;                  ///< grasped from the side (the hand horizontal)
  PickRecord held_record;            ///< filled while holding, moved to out.picks on release
  VecX q_rest;                       ///< where the arm rests: the last plan's end, or where it stopped
  double gripper_opening = 0;        ///< [m] the gripper's last goal
  std::optional<Plan> plan;          ///< the current plan (PlanMTCPick / PlanMTCPlace → ExecuteMTCPlan)
  std::optional<Pose> over_target;   ///< set when a place plan has brought the held object over its target
  double over_target_turn = 0;       ///< [rad] that plan's place_turn
  std::vector<Vec3> place_slots;     ///< the place grid's slots ComputePlacePosition gave (an object with no model placed at one is judged in it)
  std::vector<Vec3> place_failed;    ///< targets a place of the object still held failed at (ComputePlacePosition next_free passes them by)
  std::vector<Pose> failed_grasps;   ///< grasps whose execution failed (not chosen again)
  std::optional<Vec3> failed_pick_at;  ///< the grasp's TCP when the last pick failed (none once a pick succeeds)
  std::vector<Obstacle> seen_obstacles;  ///< obstacles not part of the cell, as last sensed (planned around)
  /// Camera mode with objects of no model, when a picture asks for it (keep_view): the last view
  /// perceived (its camera and depth) and each of its pixels' segment (0: none, k + 1: the k-th).
  bool keep_view = false;
  std::shared_ptr<const Frame> last_view;
  std::shared_ptr<const std::vector<uint16_t>> last_segments;
  /// The last pick plan executed: the TCP at its grasp and how far it opens each finger (pictures).
  struct ChosenGrasp {
    Pose T_world_tcp = Pose::Identity();
    double opening = 0;  ///< [m] per finger
  };
  std::optional<ChosenGrasp> last_grasp;
  /// Camera mode: the last registration against the cell (RegisterCamera), as a correction of the
  /// extrinsics otherwise held (in the camera's frame: it moves with a camera on the arm).
  std::optional<Pose> T_extrinsics_registered;
  FaultHooks* faults = nullptr;      ///< fault injection, if any
  ExternalComponent* external = nullptr;  ///< the worker's external component (external.command), if the tree asks one
  int picking = -1;                  ///< the object whose pick is being executed (-1: none)
  std::map<int, double> last_touch;  ///< per object, when the robot last touched it [s, simulated] (metrics)
  std::map<int, std::string> why_not;  ///< per object, why its last grasp or push could not be planned
  size_t failures_at_last_place = 0;   ///< out.failures' size when the last object was let go of at its target

  // The simulator's side of the same objects: bookkeeping for the records, the weld, the drop
  // monitor and fault injection, read only in a TruthScope (never by a decision).
  /// Camera mode: the first id a detection gets (ids below it are the simulator's, or a ghost
  /// an injected false detection made).
  static constexpr int kFirstDetectionId = 2000;
  int next_detection_id = kFirstDetectionId;
  std::map<int, int> truth_of;  ///< camera mode: a detection's id -> the simulator's object it matched (-1: none)
  int held_truth = -1;          ///< the simulator's index of the object really in the hand, -1 for none
  bool attempt_open = false;    ///< the last grasp attempt is not yet decided (out.grasp_attempts.back())
  int looked_at_picks = -1;     ///< camera mode: picked.size() when the bin was last looked at again (objectsInBin)
  /// The simulator's index of the robot's object `id`, or -1 (a false detection, a ghost).
  int truthIndex(int id) const;

  /// What the trial achieved and when (fault recovery is measured against these).
  struct Milestone {
    std::string what;  ///< "perception", "plan:<stage>", "pick", "place", "home"
    double sim_time;   ///< [s] since the trial started
    double compute;    ///< [s] compute wall time spent in the trial so far
  };
  std::vector<Milestone> milestones;
  void milestone(const std::string& what);
  double computeSoFar() const;
  /// Senses the obstacles that are not part of the cell into seen_obstacles; true when they
  /// changed. None in the hardcoded mode, which senses nothing, nor in camera mode, whose only
  /// sensor is the camera (its unexplained points are not obstacles yet).
  bool senseObstacles();

  // Bookkeeping.
  StageRecord& stage(const std::string& name);
  /// Records an action's failure (the trial's failure unless the tree recovers) and returns it.
  /// A halt (kHalted) is only listed: the tree stopped the action, so the trial's failure (and
  /// any recovery) is whatever made it do so.
  Failure fail(const Failure& f);
  /// The last failure recorded that no action went on after (not a halt), or nullptr.
  const RecordedFailure* unhandledFailure() const;
  /// An action is starting: failures recorded so far were handled by the tree.
  void actionStarted();
  double& computeBucket(TimeBucket b);
  double& executeBucket(TimeBucket b);
  double simTime() const;  ///< [s] since the trial started

  /// Known models' scoring: the camera's last capture as the truth has it (ScoringView), kept by
  /// the campaign's camera source. Only a TruthScope reads it; nullptr when there is none.
  void setScoringView(const ScoringView* view) { scoring_view_ = view; }
  const ScoringView* scoringView(const TruthScope&) const { return scoring_view_; }

 private:
  const ScoringView* scoring_view_ = nullptr;
};

}  // namespace mm
