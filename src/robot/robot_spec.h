// RobotSpec: the robot's numbers as written in robots/<name>/<name>.yaml (the single source of
// kinematics, limits, masses and collision primitives for a serial arm with a parallel gripper).
#pragma once
#include <array>
#include <string>
#include <vector>

namespace mm {

struct JointSpec {
  std::string name;
  double a = 0, d = 0, alpha = 0;  ///< modified DH of this joint [m, m, rad]
  double lower = 0, upper = 0;     ///< position limits [rad]
  double velocity = 0;             ///< [rad/s]
  double acceleration = 0;         ///< [rad/s^2]
  double jerk = 0;                 ///< [rad/s^3]
  double effort = 0;               ///< [N m]
};

struct ShapeSpec {
  enum class Type { kCapsule, kCylinder, kBox, kSphere };
  Type type = Type::kSphere;
  std::array<double, 3> from{}, to{};  ///< capsule/cylinder axis end points [m]
  std::array<double, 3> pos{};         ///< box/sphere center [m]
  std::array<double, 3> half{};        ///< box half sizes [m]
  double radius = 0;                   ///< [m]
};

struct LinkSpec {
  std::string name;
  double mass = 0;  ///< [kg]
  std::vector<ShapeSpec> shapes;  ///< in the link frame
};

struct GripperSpec {
  double travel = 0.04;     ///< [m] per finger
  double max_force = 70;    ///< [N] per finger
  double velocity = 0.2;    ///< [m/s]
  double finger_z = 0.0584; ///< [m] finger joint origin along hand z
  double pad_friction = 1.5;
};

struct RobotSpec {
  std::string file;  ///< where it was read from
  std::string name, base_link, tip_link;
  std::vector<JointSpec> joints;  ///< arm joints, base to tip
  double flange_d = 0, hand_yaw = 0, tcp_offset = 0;
  std::vector<double> home;  ///< [rad], dim joints.size()
  double damping = 0, armature = 0;
  GripperSpec gripper;
  /// Links in order: base, one per joint, hand, left finger, right finger.
  std::vector<LinkSpec> links;

  std::string directory() const;
  std::string mjcfPath() const;  ///< <dir>/<name>.xml
  std::string urdfPath() const;  ///< <dir>/<name>.urdf
};

/// Reads and validates a robot YAML. Throws InputError naming file:line and what was expected.
RobotSpec loadRobotSpec(const std::string& path);

}  // namespace mm
