// The task layer's own helpers, shared by its action families (perceive, pick, place, push,
// moves, plan execution): the planning scene, IK near and far, a joint-space connection with its
// time parameterization, blends, plan steps. Internal to src/task/: nothing outside includes it.
#pragma once
#include <chrono>
#include <functional>
#include <string>

#include "task/pick_place.h"

namespace mm {

using Clock = std::chrono::steady_clock;
inline constexpr double kSupportTolerance = 0.003;  ///< [m] a held object may touch its support this much
/// [m] as lifted off, a held mesh object (checked as its convex pieces' boxes) may overlap its
/// neighbours this much
inline constexpr double kPiecesLiftTolerance = 0.008;
inline constexpr double kLimitMargin = 0.05;        ///< [rad] grasp and place solutions keep off the limits
/// [rad] A plan's start and where the arm was last sent. Known seam: a plan that follows a
/// straight-line move starts from the line's last IK waypoint, while the arm was sent to the last
/// sample of that line's trajectory (IK from the previous 2 ms sample): up to 2.2 mrad apart on
/// the quickstart (measured), which is the 0.0022 rad "max tracking error" it reports. Left as it
/// is so that the outcomes stay those of the recorded chain; this check catches real jumps.
inline constexpr double kStartTolerance = 0.01;
inline constexpr double kReleaseClearance = 0.003;  ///< [m] per finger: the pads this far off the object end a release

/// Where a trajectory leaves the arm. A straight line's last sample is its own IK solution of the
/// goal, reached from the line's previous samples: for a redundant arm it may differ (in the null
/// space) from the waypoint the line was planned to, so plans end, and hold, where their
/// trajectories end.
VecX endOf(const JointTrajectory& t);
/// [s] Wall time since `t`.
double since(Clock::time_point t);
/// A perceived object as a planning-scene obstacle (a box or a cylinder).
Obstacle boxOf(const ObjectState& o);
/// An object as the planner avoids it: a mesh object of several convex pieces as one box per
/// piece (in the object's frame: an L, a ring or a cup leaves room where its bounding box has
/// none), anything else its box.
std::vector<Obstacle> obstaclesOf(const ObjectState& o);
/// Whether the object `index` has been picked in this trial.
bool picked(const TrialContext& ctx, int index);
/// The world as the planner knows it: the static cell, the obstacles sensed, the perceived objects
/// not yet picked (but `exclude`), the objects let go of at their targets (but `exclude`), and the
/// held object when `attached`.
PlanningScene planningScene(const TrialContext& ctx, int exclude, bool attached);
/// The cell's known parts (ctx.statics) with their sides grown so that a robot padded by `padding`
/// keeps at least options.wall_padding from them: horizontally, by what `padding` falls short of
/// it; their tops stay (a low object's fingertips come near the floor).
std::vector<Obstacle> wallPaddedStatics(const TrialContext& ctx, double padding);
/// The checker of `scene` (a planningScene: the statics first) with the robot padded by `padding`
/// and the statics as wallPaddedStatics.
std::unique_ptr<CollisionChecker> wallPaddedChecker(const TrialContext& ctx, PlanningScene scene, double padding);
/// IK by one descent from the seed (a straight line's samples stay on its branch), converged far
/// below the control period's resolution.
IkFunction ikNear(TrialContext& ctx, Rng& rng);
IkFunction ikNear(TrialContext& ctx);
/// The configured solver, from `seed`, kept kLimitMargin inside the limits, nearest the seed (of
/// those `valid` accepts, when given).
IkResult ikFar(TrialContext& ctx, const Pose& T, const VecX& seed, Rng& rng, std::function<bool(const VecX&)> valid = nullptr);
IkResult ikFar(TrialContext& ctx, const Pose& T, const VecX& seed);
/// A joint-space path from `start` to `goal` (the optional optimizer after the planner, CHOMP,
/// counts as planning) and its time parameterization. `checker` validated the path: it also judges
/// the samples of methods that leave the straight segments, which back off where one is invalid.
Failure connect(TrialContext& ctx, const std::string& stage, CollisionChecker& checker, const PlanningScene& scene,
                const VecX& start, const VecX& goal, JointTrajectory& out);
/// Blends the joint-space move `connect` into the straight line after it (motion.blend_radius,
/// planning/blend.h), the blended samples checked with `checker`. Returns the whole of `connect`
/// as it was when it now ends moving (the path a stop brakes along), else an empty trajectory.
JointTrajectory blendIntoLine(TrialContext& ctx, JointTrajectory& connect, JointTrajectory& line, CollisionChecker& checker);
/// Plan steps: a trajectory (with the gripper's opening and whether it carries the object), a
/// gripper action holding the arm at `q_hold`, a marker (attach, detach).
PlanStep trajectoryStep(const std::string& stage, JointTrajectory t, double opening, bool holding);
PlanStep gripperStep(const std::string& stage, const VecX& q_hold, double opening);
PlanStep markerStep(const std::string& stage, PlanStep::Kind kind);

}  // namespace mm
