// The task layer's tunables (filled from the experiment's declared parameters).
#pragma once
#include <algorithm>
#include <string>
#include <vector>

#include "core/config.h"
#include "grasp/grasp.h"
#include "kinematics/ik.h"
#include "planning/cartesian.h"
#include "planning/planner.h"
#include "planning/trajectory.h"

namespace mm {

/// An external component: the user's program, started once per worker, that answers each
/// perception over the process protocol (perception/external_protocol.h; task/external_component.h).
struct ExternalOptions {
  std::string command = "none";  ///< the program and its arguments, split at spaces (no shell; a name is looked up in PATH); "none"
  std::string cwd = ".";  ///< its working directory (a default relative path: to the project root)
  double timeout = 60;   ///< [s] wall clock: the longest an answer may take (a safety net, never an outcome)
  std::string frame = "camera";  ///< the frame its answers are in: "camera" or "world" (an answer in another is refused)
  bool oracle = false;   ///< the renderer's segmentation is given to it: a declared oracle run
  /// The command split at spaces (empty words dropped); none for "none".
  std::vector<std::string> argv() const;
};

struct TaskOptions {
  /// Keys in the sections grasp, motion, kinematics, planning, success and place.
  void declare(ConfigArchive& a);
  PlannerOptions planner;
  double padding = 0.01;                 ///< [m] robot inflation against the world when planning
  /// [m] the least clearance from the sides of the cell's known parts in checks padded less (the
  /// depth's noise is not theirs, but the arm's tracking error is); 0: off
  double wall_padding = 0.0;
  std::string checker = "spheres+fcl";   ///< collision checker: "spheres", "spheres+fcl" or "fcl"
  std::string time_parameterization = "jerk_limited";  ///< joint paths: a name of timeParameterizationNames()
  std::string optimizer = "none";        ///< "none" or "chomp" after the planner
  LimitScaling scaling{0.5, 0.5};        ///< fraction of velocity / acceleration limits
  CartesianOptions cartesian;
  std::string ik_solver = "auto";       ///< see ikSolverNames()
  IkRequest ik;                          ///< tolerances and budgets of the grasp/place IK
  GraspOptions grasp;
  int max_grasp_candidates = 8;
  double approach_distance = 0.10;       ///< [m] pre-grasp above the grasp
  double lift_height = 0.15;             ///< [m]
  double place_clearance = 0.005;        ///< [m] object bottom above the surface at release
  double retreat_distance = 0.10;        ///< [m]
  double push_distance = 0.05;           ///< [m] how far a push moves an object
  double drag_depth = 0.0;               ///< [m] a drag's fingertips this far into the object's top (0: no drags)
  double grasp_force = 40.0;             ///< [N] per finger
  bool payload_compensation = true;      ///< the servo knows the held object's nominal mass
  double finger_margin = 0.012;          ///< [m] per finger beyond the object's half width when open
  /// Where grasp candidates come from: the perceived objects' models (grasp/grasp.h), the depth
  /// camera's points with no model (grasp/cloud_grasps.h), or an external component (`external`),
  /// each of the last two held by the perceived object it closes on.
  enum class GraspSource { kModel, kCloud, kExternal };
  ExternalOptions external;
  GraspSource grasp_source = GraspSource::kModel;
  int cloud_seeds = 400;                 ///< cloud grasps: seeds drawn a view
  /// [m] cloud grasps: the fingers and the hand inflated by this against the observed points when
  /// the detector clears a hand, and in the checks of those candidates' approach, lift and connect
  /// (the depth's noise; `padding` is free motion's, a centimetre that fills the gaps of a pile)
  double cloud_padding = 0.004;
  /// [m] a grasp from the camera's points: its padding, in the detector and in every check of its
  /// motions near the pile (the planner's, if that is less)
  double cloudGraspPadding() const { return std::min(padding, cloud_padding); }
  double cloud_bite = 0.012;             ///< [m] cloud grasps: the fingertips at least this far past the seed (GPD's init_bite: 0.01)
  double cloud_cone = 0.35;              ///< [rad] cloud grasps: a contact face's normal within this of the closing axis (GPD's 20 degrees)
  double cloud_snap_down = 0.0;          ///< [rad] cloud grasps: a view with no candidate is looked at again, approaches this near straight down straight down (0: never)
  double cloud_weak_score = 0.0;         ///< cloud grasps: a view whose best candidate scores below this is looked at again too (with cloud_snap_down; 0: never)
  int cloud_floor_contacts = 4;          ///< cloud grasps, the second look: cells of each pad (of 3 x 6) the object fills where the fingertips are at the floor
  double tight_margin = 0.0;             ///< [m] finger margin and approach padding when nothing fits otherwise (0: never; clutter: 0.004)
  bool weld = false;                     ///< weld-on-grasp (attach plugin) instead of friction
  double drop_distance = 0.03;           ///< [m] object this far from its in-hand pose = dropped
  double path_tolerance = 0.05;          ///< [rad] a joint this far from its setpoint stops the motion
  double settle_velocity = 1e-3;         ///< [rad/s] still, at a move's end
  bool close_early = false;              ///< the grasp's close starts as the approach's last setpoint is sent
  bool settle_every_move = true;         ///< hold the arm still at every move's end (false: only before the gripper acts and after pushes)
  double blend_radius = 0.02;            ///< [m] pre-grasp and pre-place blends (planning/blend.h; 0: none; only without settle_every_move)
  double contact_force_limit = 20;       ///< [N] an external contact force past this stops the motion (0: off)
  double push_force_limit = 100;         ///< [N] the same during a push (a contact task)
  double scene_update_period = 0.1;      ///< [s] obstacle sensing while moving (0: none)
  double settle_time = 0.5;              ///< [s] simulated rest before the evaluation
  // The place area: slots in a grid centred on the place target (ComputePlacePosition).
  int place_rows = 1, place_columns = 3;
  double place_pitch = 0.06;             ///< [m] between slot centres
  bool place_any_yaw = false;            ///< an object with no declared symmetry may be set down turned about the vertical
  // Success criteria.
  double tolerance_position = 0.02;      ///< [m] horizontal distance to the place target
  double tolerance_orientation = 0.1745; ///< [rad] (10 degrees)
};

}  // namespace mm
