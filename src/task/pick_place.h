// Pick and place as actions a behavior tree calls one at a time, the stages of the source's
// MoveIt Task Constructor task: CurrentState -> OpenGripper -> Connect(pre-grasp) -> GraspPose+IK
// -> Approach -> Close -> Attach -> Lift -> Connect(pre-place) -> Place -> Open -> Detach -> Retreat,
// then home. Planning returns a plan or a typed failure (stage, kind, reason) and takes no
// simulated time; execution is a Motion the executor advances period by period, which the tree can
// halt. Each stage is recorded with its compute wall time apart from its simulated time.
#pragma once
#include <memory>
#include <vector>

#include "task/trial_context.h"

namespace mm {

/// [m] per finger: fingers closed to less hold nothing (closed on nothing they meet at 0; a hollow
/// object's 5 mm wall holds each 2 to 2.5 mm open).
inline constexpr double kEmptyGrip = 0.001;

struct CloudGraspOptions;  // grasp/cloud_grasps.h

// ---- perception ---------------------------------------------------------------------------

/// Perceives the objects in the bin into ctx.objects (without those already picked).
Failure detectObjects(TrialContext& ctx);
/// Camera mode: the camera registered against the cell's static boxes from a fresh frame
/// (perception/cell_registration.h); perception uses that pose from then on. Nothing to do (no
/// failure) in the other modes.
Failure registerCamera(TrialContext& ctx);
/// Indices into ctx.objects of the objects not yet picked, the most room to a neighbour first
/// (a stable order for equal room).
std::vector<int> objectsByRoom(const TrialContext& ctx);
/// Index into ctx.objects of the most accessible object: the first by room (objectsByRoom) that
/// has a grasp passing every check (graspable), else the first by room; -1 when there is none.
int mostAccessibleObject(TrialContext& ctx);
/// The perceived object nearest `T_world_object` (within 5 cm), or -1.
int perceivedObjectAt(const TrialContext& ctx, const Pose& T_world_object);
/// Objects in the bin as the robot knows it (IsBinNotEmpty): in the ground-truth modes the
/// sensor's count over its crop box; in camera mode the detected objects not yet picked, and,
/// when there are none, a fresh look (at most once a pick).
int objectsInBin(TrialContext& ctx);
/// Objects in the bin now (the held one is not), from the simulator's truth: for scoring.
int objectsInBinTruly(const TrialContext& ctx);

// ---- pick ---------------------------------------------------------------------------------

/// Grasp candidates for `object`, best first (neighbours: the other perceived objects and the
/// cell's statics), scored for the robot's gripper.
std::vector<GraspCandidate> graspCandidates(TrialContext& ctx, const ObjectState& object);
/// A frame of the perception camera, its extrinsics those the robot holds (the calibration's,
/// corrected by the last registration against the cell), the robot's own points taken out
/// (removeRobotPoints; so are they from the views segmented for objects with no model, not from
/// those of the known objects' fitter); false with `why` when there is none.
bool captureView(TrialContext& ctx, Frame& frame, std::string* why);
/// The robot's own points taken out of `frame`, as MoveIt's self filter does: a pixel whose point
/// lies in the region perception looks at (`o`'s crop, with 5 cm around it) and within the robot's
/// collision spheres padded by 1.5 cm, at joint positions `q` and `finger_opening` per finger (what
/// it measures of itself), has no depth. An arm left in the bin is then no object and no obstacle.
void removeRobotPoints(const RobotModel& robot, const VecX& q, double finger_opening, const PerceptionOptions& o, Frame& frame);
/// Model-free candidates (grasp/cloud_grasps.h) from a fresh view of the perception camera, each
/// under the perceived object not yet picked that its pads close on, objects in the order of their
/// best candidate; a candidate closing on no perceived object or on two is dropped. Records stage
/// "cloud_grasps"; a failure (no view, no candidate) is returned, not recorded.
Failure cloudGraspCandidates(TrialContext& ctx, std::vector<std::pair<ObjectState, std::vector<GraspCandidate>>>& out);
/// Candidates from the external component (ctx.external) given a fresh view of the perception
/// camera, each under the perceived object its pads close on (as cloudGraspCandidates), best first
/// by the component's scores. Recorded as stage "external_grasps" and one entry of the trial's
/// external_calls; a call that did not answer (crash, hang, not the protocol, its own error) is a
/// perception failure whose reason says which; returned, not recorded.
Failure externalGraspCandidates(TrialContext& ctx, std::vector<std::pair<ObjectState, std::vector<GraspCandidate>>>& out);
/// The grasp options of `task` with the gripper's stroke, pad friction and geometry (the pads'
/// extent and the hand body's, in the TCP frame) filled in.
GraspOptions graspOptionsFor(const GripperSpec& gripper, const TaskOptions& task);
/// The model-free detector's options as a trial runs it: the gripper's geometry, the task's finger
/// margin, padding for cloud grasps and seeds, and the perception's region (the crop).
CloudGraspOptions cloudGraspOptionsFor(const GripperSpec& gripper, const TaskOptions& task, const PerceptionOptions& perception);
/// Whether one of the object's candidates passes selectGrasp's checks (IK, collision, approach,
/// lift) now; records nothing and draws from a copy of the IK stream.
bool graspable(TrialContext& ctx, const ObjectState& object);
/// The first candidate (in order, from `first`, at most options.max_grasp_candidates tried) that
/// passes filterGrasp and has not failed before in this trial, with the pre-grasp
/// `approach_distance` [m] above the grasp (negative: options.approach_distance). Records stage
/// "grasp_pose_ik" (not ok when it fails) but not the failure itself: the caller records it
/// (TrialContext::fail) when it gives up.
Failure selectGrasp(TrialContext& ctx, const ObjectState& object, const std::vector<GraspCandidate>& candidates,
                    size_t first, GraspSolution& out, double approach_distance = -1);
/// The pick from where the arm rests: open, connect to the pre-grasp, approach, close, attach,
/// lift. Records stage "connect_pregrasp".
Failure planPick(TrialContext& ctx, const GraspSolution& grasp, Plan& out);

// ---- place and the rest -------------------------------------------------------------------

/// The place of the held object so that it rests at `T_world_object`: connect to the pre-place,
/// lower; with `release`, also open, detach and retreat. Records "place_pose_ik", "connect_place".
Failure planPlace(TrialContext& ctx, const Pose& T_world_object, bool release, Plan& out);

/// The place grid's slots as offsets from the place target in the world (place.rows along y,
/// place.columns along x, place.pitch apart, centred on it), nearest the centre first, row by row among equals.
std::vector<Vec3> placeGridOffsets(const TaskOptions& o);

/// Of `slots`, the first that no placed object's target is within half a `pitch` of (in the
/// plane) and no failed place was; when every free one has failed places, the one with fewest; -1
/// when every slot holds an object.
int nextFreeSlot(const std::vector<Vec3>& slots, const std::vector<Vec3>& placed, const std::vector<Vec3>& failed, double pitch);
/// Home from where the arm rests. Records "plan_home".
Failure planHome(TrialContext& ctx, Plan& out);
/// A push that moves `object` (one no grasp fits: flush against a neighbour or a wall) clear:
/// the closed fingers go down beside it, push it motion.push_distance horizontally along one of
/// its face normals (towards free room in the bin, inside the walls, away from the other
/// objects), and go up. Records "plan_push"; FAILURE when no direction has room.
Failure planPush(TrialContext& ctx, const ObjectState& object, Plan& out);
/// A straight retreat of `distance` [m] up from where the arm rests, checked without padding (the
/// way out of a spot where the hand touches); from inside a static part of the cell, first a short
/// horizontal move out of it, the way it leaves soonest. Records "plan_safe".
Failure planRetreatUp(TrialContext& ctx, double distance, Plan& out);
/// The gripper to `opening` [m] per finger, recorded as `stage`: opening lets go of a held object;
/// closing on an object between the fingers (a perceived one within 2 cm of the TCP) takes hold of
/// it.
Plan gripperPlan(TrialContext& ctx, double opening, const std::string& stage);

/// The plan's execution as a motion for the executor. Its end (success or failure) is recorded
/// into the context when it finishes; call finishExecution() with it once it has ended.
std::unique_ptr<Motion> executePlan(TrialContext& ctx, Plan plan);
/// Books an ended execution: its failure (recorded with its stage), or its end as where the arm
/// rests. Returns the failure (kNone on success; kHalted when halted).
Failure finishExecution(TrialContext& ctx, Motion& execution);

// ---- the end of a trial -------------------------------------------------------------------

/// After the tree: lets the objects settle, measures each let-go object against its target in the
/// simulator and fills the outcome (success, failure, errors, times, counts).
void finishTrial(TrialContext& ctx, bool tree_succeeded);

/// Runs `m` on the context's executor to its end (blocking: no tree above).
Failure runMotion(TrialContext& ctx, std::unique_ptr<Motion> m);

/// The whole pick and place as one blocking chain, no tree and no recovery: perceive, pick the most
/// accessible object, place it to rest at `T_world_target`, go home, evaluate. The reference the
/// trees are compared with.
void runPickAndPlace(TrialContext& ctx, const Pose& T_world_target);

}  // namespace mm
