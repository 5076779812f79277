// A robot's home in its cell. Robot files often give none (a URDF cannot), and each joint at 0 is
// rarely a pose a cell can start from (an arm stretched out through the table). So: the home the
// robot's files give (an arm YAML's, a companion's, an MJCF keyframe 'home'), checked clear of the
// scene; or, when they give none, one found above the bin.
#pragma once
#include "campaign/experiment.h"
#include "robot/robot_model.h"

namespace mm {

/// `robot` with its home resolved for the cell of `e`: the files' home, which must be clear of the
/// scene's static obstacles (else InputError naming the robot's file and the colliding pair); or,
/// when the files give none, the clear IK solution of a gripper-down pose above the bin — 0.2 to
/// 0.4 m over its rim, eight yaws, several seeds — that stays farthest from the joint limits
/// (InputError when none is found). Deterministic: fixed seeds, the IK's work-unit budget.
RobotModel resolveHome(const Experiment& e, const RobotModel& robot);

}  // namespace mm
