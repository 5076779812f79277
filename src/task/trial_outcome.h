// One trial's record: what happened, where it failed and why, how long each stage took.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "core/failure.h"
#include "core/geometry.h"
#include "core/pose.h"

namespace mm {

struct StageRecord {
  std::string name;
  bool ok = true;
  double compute_seconds = 0;  ///< wall time of planning/IK/perception in this stage
  double sim_seconds = 0;      ///< simulated execution time in this stage
};

/// One object a camera perception found, against the simulator's truth (evaluation only).
struct DetectionRecord {
  int object = -1;        ///< the true object it was matched to (nearest centre within 3 cm); -1: none (a false detection)
  double time = 0;        ///< [s] simulated, since the trial began
  double centre_error = 0;    ///< [m]
  double rotation_error = 0;  ///< [rad] up to the box's symmetries
  double mssd = 0;            ///< [m] BOP's maximum symmetry-aware surface distance
};

/// Known models (perception.known_models): one object a view could have posed, as BOP's targets
/// (its visible fraction at least 0.1), and the errors of the pose matched to it (evaluation only).
struct PoseTargetRecord {
  int object = -1;              ///< the simulator's index
  double visible_fraction = 0;  ///< its pixels in the view / its pixels drawn alone (the renderer's labels, its model)
  double diameter = 0;          ///< [m] its model's
  bool posed = false;           ///< a detection of its own model was matched to it (else the errors are -1, vsd empty)
  double mssd = -1;             ///< [m]
  double mspd = -1;             ///< [px] in this view's image
  std::vector<double> vsd;      ///< BOP's VSD at tau = 0.05, 0.10, ..., 0.50 of the diameter (delta 15 mm)
};

/// Known models: one view's pose estimation, its time and its targets.
struct PoseViewRecord {
  double time = 0;         ///< [s] simulated, since the trial began
  int width = 0;           ///< [px] the image's (BOP scales MSPD by 640 / width before its thresholds)
  int segments = 0;        ///< the depth's segments posed
  int posed = 0;           ///< of them, posed by a model
  double seconds = 0;      ///< [s] wall: the view's pose estimation (every segment's; measured, decides nothing)
  std::vector<PoseTargetRecord> targets;
};

/// The camera registered again against the cell (RegisterCamera): the correction it found.
struct RegistrationRecord {
  double time = 0;         ///< [s] simulated, since the trial began
  double rotation = 0;     ///< [rad] the correction's angle, from the extrinsics held before
  double translation = 0;  ///< [m] how far it moved the camera's centre
  double bin_shift = 0;    ///< [m] the farthest it moved a point of the bin (what the camera sees there)
  double rms = 0;          ///< [m] the cell's surfaces against the image's points at the end
  int points = 0;          ///< points matched to the cell's surfaces
};

/// One call of the external component (external.command) for a view: what came back, how many
/// grasps, and how long it took.
struct ExternalCallRecord {
  double time = 0;            ///< [s] simulated, since the trial began
  std::string result;         ///< answer, error, crash, timeout, not_protocol, cannot_start or io_error
  std::string reason;         ///< for all but answer
  double write_seconds = 0;   ///< [s] wall: the view's images written
  double answer_seconds = 0;  ///< [s] wall: the request sent until the answer read (the component's own time, apart)
  int grasps = 0;             ///< candidates in the answer
  int grasps_on_objects = 0;  ///< of them, closing on one perceived object (tried by the pick)
  std::string answer;         ///< results answer and error: the component's answer line as it came (a replay answers from it)
};

/// One object the robot let go of, and where it ended up.
struct PickRecord {
  int object = -1;                 ///< index in the scene's object pool
  Vec3 half_size = Vec3::Zero();   ///< [m] as perceived
  Pose T_world_target = Pose::Identity();  ///< where it should rest
  bool at_target = false;          ///< released by a place (not dropped elsewhere)
  bool placed = false;             ///< evaluated within the tolerances
  double position_error = 0;       ///< [m] horizontal
  Vec3 offset = Vec3::Zero();      ///< [m] where it rests minus its target (world frame)
  double orientation_error = 0;    ///< [rad] about the object's symmetry (-1: no model, no target orientation)
  double place_turn = 0;           ///< [rad] its target turned about the vertical from the one asked (place.any_yaw)
  int grasp_candidates_tried = 0;
  double grasp_opening = 0;        ///< [m] per finger after closing
  double neighbours_moved = 0;     ///< [m] the farthest another object moved while this one was picked
  double in_hand_slip = 0;         ///< [m] how far it moved in the hand from the fingers closing to the release (ground truth)
  /// A mesh object's convex pieces as perceived (the planner avoids it as them once placed); not recorded.
  std::shared_ptr<const std::vector<ConvexPiece>> pieces;
  std::string grasp_type;          ///< "top_down", "side", "cloud" or "external" (the component that proposed it) (empty: taken hold of without a planned grasp)
  double grasp_deviation = 0;      ///< [m] the achieved in-hand pose's offset from the planned one, at the fingers' closing (ground truth)
  double grasp_deviation_angle = 0;  ///< [rad] the same, rotation (up to the object's symmetries)
  bool first_pass = false;         ///< let go of at its target with no failure since the previous one was
  std::string reason;              ///< why it is not placed
};

/// One grasp candidate filterGrasps looked at: its scores and what became of it.
struct GraspTry {
  std::string type;            ///< "top_down", "side", "cloud" or "external" (the component that proposed it)
  double score = 0;
  double closure_margin = 0;   ///< [rad] force-closure margin (atan(mu) minus the larger contact angle)
  double contact_area = 0;     ///< [m^2] pad area the object covers
  double torque_arm = 0;       ///< [m] centre of mass to the grasp axis
  double clearance = 0;        ///< [m] open fingertips to the nearest neighbour
  std::string result;          ///< "chosen", or why it was dropped
  bool turned = false;         ///< a cloud candidate's second try, the hand turned half a turn about its approach
};

/// One selection of a grasp for an object (a SelectGrasp / the chain's grasp stage).
struct GraspSelection {
  int object = -1;
  std::string shape;          ///< "box" or "cylinder"
  int candidates = 0;         ///< generated
  std::vector<GraspTry> tried;  ///< in order, up to the chosen one or the limit
};

/// An object still in the bin when the trial ended, and why it was not picked.
struct LeftRecord {
  int object = -1;
  Vec3 position = Vec3::Zero();  ///< [m] world, ground truth
  double tilt = 0;               ///< [rad] of its axis nearest the vertical from the vertical
  std::string reason;            ///< its last grasp's or push's failure; "not tried" when none was planned
};

/// One closing of the fingers on a chosen grasp candidate: the clutter-removal protocol's attempt
/// (pushes are not attempts). Scored from the simulator's truth after the fact.
struct GraspAttempt {
  int object = -1;     ///< the object the fingers closed on (else the one nearest the grasp), -1: none near
  /// in_tray (that object released in the tray: a success), missed (nothing between the fingers,
  /// they did not close, or no object there), dropped, let_go_elsewhere (let go of away from its
  /// place target), halted (the closing stopped by the tree), or held_at_end.
  std::string result = "held_at_end";
  bool success() const { return result == "in_tray"; }
};

/// A failure an action reported during the trial, and whether the tree went on after it.
struct RecordedFailure {
  Failure failure;
  double sim_time = 0;   ///< [s] since the trial started
  bool handled = false;  ///< the tree started another action after it (a recovery attempt)
};

/// A fault injected into the trial and what became of it.
struct FaultRecord {
  std::string kind;          ///< e.g. "grasp_slip"
  std::string stage;         ///< the stage it was injected in
  double sim_time = 0;       ///< [s] onset, since the trial started
  bool detected = false;     ///< a failure was recorded after the onset
  double detected_time = -1; ///< [s]
  std::string detected_by;   ///< that failure's stage and kind
  std::string recovery;      ///< the stages the tree ran after the detection, until it recovered or ended
  /// no_effect (nothing failed after it); recovered (the interrupted stage succeeded later and the
  /// trial succeeded, or failed only after a later fault); given_up (a kind no action can recover
  /// from, noticed and moved on from without harm); superseded (its object was then taken away);
  /// unrecovered.
  std::string outcome;
  double mttr = -1;          ///< [s] onset until the interrupted stage next succeeded, compute time included
};

/// One trial's outcome. Times are [s]; errors [m] and [rad].
struct TrialOutcome {
  bool success = false;
  std::string failure_stage, failure_reason;
  FailureKind failure_kind = FailureKind::kNone;
  bool sim_unstable = false;
  bool dropped = false;
  int target_object = -1;       ///< the first object picked
  int objects_in_bin = 0;       ///< detected at the first perception
  int objects_left_in_bin = 0;  ///< at the end
  int grasp_candidates_tried = 0;
  int pushes = 0;  ///< pushes executed to make room for a grasp
  // The source's time breakdown (compute stages in wall time, execution in simulated time).
  double perception_time = 0, plan_pick_time = 0, execute_pick_time = 0, plan_place_time = 0,
         execute_place_time = 0, return_home_time = 0, total_time = 0;
  double sim_time = 0;      ///< simulated seconds of the whole trial (deterministic)
  double compute_time = 0;  ///< wall seconds of the blocking computation
  double place_position_error = 0, place_orientation_error = 0;  ///< the worst placed object's (orientation: -1 with no model)
  double in_hand_slip = 0;  ///< [m] the most any object moved in the hand between grasp and release (ground truth)
  int collision_count = 0;
  std::vector<std::string> collision_log;
  double max_tracking_error = 0;
  double max_external_force = 0;  ///< [N] the largest external contact force on the robot (Hardware::externalForce)
  int non_target_contacts = 0;    ///< episodes of the robot touching an object it was not picking or holding
  double neighbours_moved = 0;    ///< [m] the farthest an object moved while another was picked (pushes aside)
  long collision_checks = 0;
  double grasp_opening = 0;  ///< [m] per finger after the last close
  std::vector<PickRecord> picks;  ///< every object let go of, in order
  std::vector<GraspAttempt> grasp_attempts;  ///< every closing of the fingers on a chosen grasp, in order
  std::vector<GraspSelection> grasp_selections;  ///< every grasp selection, in order
  std::vector<DetectionRecord> detections;  ///< camera mode: every detection of every perception
  int missed_detections = 0;      ///< camera mode: objects in the bin a perception did not find
  std::vector<PoseViewRecord> pose_views;  ///< known models: every view's pose estimation, scored
  std::vector<RegistrationRecord> camera_registrations;  ///< camera mode: every RegisterCamera that succeeded
  std::vector<ExternalCallRecord> external_calls;  ///< every call of the external component
  std::vector<LeftRecord> left;   ///< every object left in the bin at the end
  std::vector<RecordedFailure> failures;
  std::vector<FaultRecord> faults;  ///< injected faults
  // Recovery: failures the tree went on after (see RecordedFailure::handled).
  bool recovery_needed = false, recovery_success = false;
  int recovery_attempts = 0;
  // The behavior tree.
  std::string tree;         ///< the tree's ID
  std::string tree_status;  ///< SUCCESS, FAILURE or TIMEOUT
  std::string ik_solver;    ///< the IK solver of grasp and place poses (kinematics.solver, auto resolved)
  long ticks = 0;
  int reported_total = -1;  ///< ReportCompletion's total, -1 if never reported
  std::vector<StageRecord> stages;
};

}  // namespace mm
