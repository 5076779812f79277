#include "task/task_options.h"

#include "planning/chomp.h"
#include "planning/collision.h"
#include "planning/time_parameterization.h"

namespace mm {

std::vector<std::string> ExternalOptions::argv() const {
  std::vector<std::string> words;
  if (command == "none") return words;
  std::string word;
  for (char ch : command + " ") {
    if (ch == ' ' || ch == '\t') {
      if (!word.empty()) words.push_back(word);
      word.clear();
    } else {
      word += ch;
    }
  }
  return words;
}

void TaskOptions::declare(ConfigArchive& a) {
  a.enter("grasp");
  a.named("mode", weld, {{"friction", false}, {"weld", true}},
          "friction: held by finger force; weld: attached on grasp (the source's attach plugin)");
  a.value("force", grasp_force, {1.0, 1000.0}, "N", "finger force limit while grasping, at most the gripper's max_force");
  a.value("close_early", close_early,
          "the fingers start closing as the approach's last setpoint is sent, while the arm settles at the grasp pose, "
          "instead of once it is still (the fault gripper_no_close blocks that close too; it is recorded in the close_gripper stage)");
  a.value("payload_compensation", payload_compensation,
          "while an object is held, the servo compensates its weight and commanded acceleration (its kind's nominal mass at "
          "the planned grasp's centre, as Franka's setLoad); false: the arm sags under it");
  a.named("source", grasp_source, {{"model", GraspSource::kModel}, {"cloud", GraspSource::kCloud}, {"external", GraspSource::kExternal}},
          "model: candidates from each perceived object's shape and pose; cloud: model-free 6-DoF candidates from the "
          "perception camera's depth image (GPD's geometry), each tried on the perceived object it closes on; external: "
          "candidates from the external component (external.command) given the same view, tried likewise (a tree's "
          "WaitForGraspCandidates may choose with its source port)");
  a.value("cloud_seeds", cloud_seeds, {10, 5000}, "", "cloud grasps: points drawn a view to build hands at");
  a.value("cloud_padding", cloud_padding, {0.0, 0.02}, "m",
          "cloud grasps: the fingers and the hand inflated by this against the camera's points when a hand is cleared, "
          "and the same padding (at most planning.padding) in the checks of their approach, lift and the move to the "
          "pre-grasp; planning.padding's centimetre fills most gaps of a pile");
  a.value("cloud_bite", cloud_bite, {0.004, 0.03}, "m",
          "cloud grasps: the fingertips reach at least this far past the point a hand is built at (a top-down hand on "
          "an object lying lower than this plus cloud_padding and 2 mm of clearance above the floor has none)");
  a.value("cloud_cone", cloud_cone, {0.1, 0.8}, "rad",
          "cloud grasps: the faces the pads meet (fitted to the outermost points between them) must face the closing "
          "axis within this, the friction cone the detector assumes (0.35: GPD's 20 degrees, a friction coefficient of "
          "0.36; at most atan of the gripper's pad friction)");
  a.value("cloud_snap_down", cloud_snap_down, {0.0, 0.5}, "rad",
          "cloud grasps: a view that gives no candidate is looked at again (as many seeds more), each approach within "
          "this of straight down taken straight down with its closing axis level, and every seed's hands turned by 45, "
          "90 and 135 degrees about its normal too (a low object's noisy top tilts its hands, and a tilted hand's far "
          "finger dips to the floor; a curved object by a wall gets hands along it); 0: no second look");
  a.value("cloud_weak_score", cloud_weak_score, {0.0, 3.0}, "",
          "cloud grasps: a view whose best candidate scores below this is looked at again as one with none "
          "(cloud_snap_down), and the two looks' candidates ranked together; 0: only a view with none. A score is the "
          "smaller pad's cells filled / 18 + the force-closure margin in rad + 0.5 x min(1, points between the pads / 100) - "
          "0.5 x the tilt from straight down in rad + 10 x the clearance beside the fingers (at most 2 cm)");
  a.value("cloud_floor_contacts", cloud_floor_contacts, {1, 4}, "",
          "cloud grasps: a contact is the object filling 4 of each pad's 3 x 6 cells (across it, along it; the "
          "outermost points between the pads, per cell); in the second look (cloud_snap_down), this many where the "
          "fingertips are down at the floor and no deeper hand holds (an object lower than two rows of the pads)");
  a.value("max_candidates", max_grasp_candidates, {1, 64}, "", "grasp candidates tried per object before the pick fails");
  a.value("finger_margin", finger_margin, {0.002, 0.04}, "m",
          "fingers open this much wider than the object's half width before the approach");
  a.value("tight_margin", tight_margin, {0.0, 0.04}, "m",
          "in clutter, when no grasp fits with finger_margin and planning.padding: the fingers open only this much wider than "
          "the object and the approach is checked with this padding (0: never)");
  grasp.declare(a);
  a.leave();

  a.enter("external");
  a.value("command", external.command,
          "an external component (your grasp detector, in any language): the program and its arguments, split at spaces "
          "(no shell; a name is looked up in PATH), started once per worker and asked over the process protocol "
          "(docs/external-components.md) for each view of grasp.source external; none: no component");
  a.path("cwd", external.cwd, "the component's working directory; paths as for robot (the default: the project's root)");
  a.value("timeout", external.timeout, {0.01, 86400.0}, "s",
          "wall clock: an answer that takes longer is recorded as a timeout (a failure of that perception) and the component "
          "is started afresh; a safety net, never an outcome of a trial that answered");
  a.choice("frame", external.frame, {"camera", "world"},
           "the frame the component's poses are in: camera (OpenCV's: x right, y down, z forward) or world; an answer "
           "that says another is not the protocol");
  a.value("oracle", external.oracle,
          "the renderer's segmentation is given to the component (images.labels): a declared oracle run, marked so in "
          "every record");
  a.leave();

  a.enter("motion");
  a.value("approach_distance", approach_distance, {0.02, 0.3}, "m", "pre-grasp and pre-place height above the grasp and place poses");
  a.value("lift_height", lift_height, {0.02, 0.4}, "m", "straight lift after the grasp");
  a.value("retreat_distance", retreat_distance, {0.02, 0.3}, "m", "straight retreat after the release (and MoveToSafe's)");
  a.value("push_distance", push_distance, {0.01, 0.2}, "m",
          "how far PushObject moves an object no grasp fits (closed fingers, along a face normal, towards free room)");
  a.value("drag_depth", drag_depth, {0.0, 0.005}, "m",
          "when the fingers have no room beside an object to push it, PushObject may drag it by its top: the closed "
          "fingertips pressed this far into its upper face, then moved along (friction; needs a bin floor less grippy "
          "than the pads); 0: no drags");
  a.value("place_clearance", place_clearance, {0.0, 0.05}, "m", "object bottom above the tray at the release");
  a.value("path_tolerance", path_tolerance, {0.001, 1.0}, "rad",
          "a joint this far from its setpoint stops the motion (the controller's protective stop, as ros2_control's JTC)");
  a.value("contact_force_limit", contact_force_limit, {0.0, 1000.0}, "N",
          "an external contact force on an arm link or the hand past this stops the motion where the joints are "
          "(a collision reflex, the protective stop on contact force; the held object's weight counts, as a wrist "
          "sensor sees it; 20 N: libfranka's example collision thresholds); 0: off");
  a.value("push_force_limit", push_force_limit, {0.0, 1000.0}, "N",
          "the same limit during a push, a contact task (Franka users raise the thresholds for those); 0: off");
  a.value("scene_update_period", scene_update_period, {0.0, 10.0}, "s",
          "while moving, the robot senses new obstacles this often and stops if one blocks the rest of its path "
          "(MoveIt's planning scene monitor); 0: never");
  a.value("velocity_scaling", scaling.velocity, {0.01, 1.0}, "", "fraction of the joint velocity limits");
  a.value("settle_velocity", settle_velocity, {1e-4, 0.1}, "rad/s",
          "a move's end is reached when every joint is within 1 mrad of it and slower than this (or after 0.3 s)");
  a.value("settle_every_move", settle_every_move,
          "hold the arm at every move's end until it is still (1 mrad, 1 mrad/s; at most 0.3 s); false: only where the gripper "
          "acts next (grasp, release) and after pushes, a move followed by another handing on as its last setpoint is sent "
          "(shorter cycles; bin clearing's 50 trials of seed 1 placed 488 of 500 cubes so, 495 with it)");
  a.value("blend_radius", blend_radius, {0.0, 0.05}, "m",
          "at the pre-grasp and the pre-place the joint-space move and the straight line after it run together (superposed, "
          "within the limits, collision-checked) while the TCP is within this distance of the corner, so the arm does not "
          "stop there; 0: it stops. Only when motion.settle_every_move is false");
  a.value("acceleration_scaling", scaling.acceleration, {0.01, 1.0}, "", "fraction of the joint acceleration limits (jerk scales alike)");
  cartesian.declare(a);
  a.leave();

  a.enter("kinematics");
  a.choice("solver", ik_solver, ikSolverNames(), "IK solver for grasp and place poses (docs/benchmarks.md compares them)");
  a.leave();

  a.enter("planning");
  planner.declare(a);
  a.choice("checker", checker, checkerNames(),
           "collision checker: our spheres (conservative), spheres confirmed by FCL (exact), or FCL");
  a.choice("time_parameterization", time_parameterization, timeParameterizationNames(),
           "time parameterization of joint-space paths: jerk_limited passes through waypoints, jerk_limited_stop and "
           "trapezoidal rest at each, totg blends corners within 0.05 rad (samples off the planned path are collision-checked)");
  a.choice("optimizer", optimizer, optimizerNames(),
           "optimizing post-processor after the planner (CHOMP-style; time-parameterize its dense paths with totg)");
  a.value("padding", padding, {0.0, 0.1}, "m", "robot inflation against the world");
  a.value("wall_padding", wall_padding, {0.0, 0.1}, "m",
          "the robot (and the object it sets down) kept at least this far from the sides of the cell's known parts (the "
          "bin's and the tray's walls) in the grasp's and the place's checks padded less (a grasp from the camera's points: grasp.cloud_padding; the "
          "tight pass: grasp.tight_margin): the parts are grown sideways by the difference, their tops not (a low "
          "object's fingertips come near the floor), and the detector of grasps from the points drops a hand whose "
          "fingers go down that near a wall; 0: off");
  a.leave();

  a.enter("success");
  a.value("position_tolerance", tolerance_position, {0.001, 0.2}, "m", "horizontal distance from the place target counted as placed");
  a.value("orientation_tolerance", tolerance_orientation, {0.001, 3.1416}, "rad", "orientation error counted as placed (about its symmetry)");
  a.value("settle_time", settle_time, {0.0, 5.0}, "s", "simulated rest before the placed objects are measured");
  a.leave();

  a.enter("place");
  a.value("rows", place_rows, {1, 20}, "",
          "rows (along y) of the place grid ComputePlacePosition fills, centred on the scene's place_target, nearest slots first");
  a.value("columns", place_columns, {1, 20}, "", "columns (along x) of the place grid (the quickstart tray holds a row of three 5 cm cubes)");
  a.value("pitch", place_pitch, {0.02, 0.5}, "m", "distance between neighbouring slots of the place grid");
  a.value("any_yaw", place_any_yaw,
          "an object with no declared symmetry (a mesh) may be set down turned about the vertical, in 30 degree steps "
          "(the least turn first), when at the target's own yaw the hand meets a neighbour; it is then judged against "
          "that turn (clutter removal: in the tray is what counts); false: only at the target's yaw");
  a.leave();
}

}  // namespace mm
