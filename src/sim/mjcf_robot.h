// Robots from any description the harness reads: an arm YAML or a URDF (robot/), or an MJCF file
// (.xml), which MuJoCo compiles (defaults, angles and autolimits resolved) and which is read here
// from the compiled model: the arm is the chain of hinge joints from the base body to the flange
// body; bodies without joints merge into the body they hang from; whatever hangs below the flange
// (a hand the file carries) is left out, the gripper being mounted there as a part. What MJCF
// lacks (velocity limits, acceleration, jerk, home, ...) comes from its companion <file>.yaml.
#pragma once
#include <string>

#include "robot/robot_model.h"

namespace mm {

/// The robot at `path` (.yaml, .urdf or .xml) with `gripper_yaml` mounted (empty: its default).
/// Throws InputError naming the file and place.
RobotSpec loadAnyRobotSpec(const std::string& path, const std::string& gripper_yaml = "");
RobotModel loadAnyRobot(const std::string& path, const std::string& gripper_yaml = "");

}  // namespace mm
