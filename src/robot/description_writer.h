// Writes a robot's MJCF and URDF descriptions from its RobotSpec, so both carry the same
// kinematics, limits, masses and collision primitives by construction.
#pragma once
#include <string>

#include "robot/robot_spec.h"

namespace mm {

/// MJCF fragment (a <mujoco> file a scene <include>s): bodies, joints, geoms, actuators
/// (torque motors on the arm joints, force motors on the fingers), the TCP site and wrist camera.
std::string writeMjcf(const RobotSpec& spec);
/// URDF: the same links; capsules become a cylinder and two spheres (URDF has no capsule).
std::string writeUrdf(const RobotSpec& spec);

}  // namespace mm
