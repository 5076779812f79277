// RobotSpec: an arm's numbers as written in robots/<name>/<name>.yaml (the single source of its
// kinematics, limits, masses and collision primitives) with a parallel gripper mounted on its
// flange, read from its own file (robots/grippers/<name>.yaml): the gripper is a part, chosen by
// the robot's default or by the experiment.
#pragma once
#include <array>
#include <string>
#include <vector>

namespace mm {

struct JointSpec {
  std::string name;
  /// Where the joint sits in the previous joint's frame and its axis there. A joint written in
  /// modified DH (`dh`) has origin Rx(alpha) Tx(a) Tz(d) and axis z; one read from a URDF keeps its
  /// origin and axis, and gets `dh` (with a, d, alpha) when they have that form.
  bool dh = true;
  double a = 0, d = 0, alpha = 0;  ///< modified DH of this joint [m, m, rad]
  std::array<double, 3> xyz{}, rpy{}, axis{0, 0, 1};  ///< origin [m], roll-pitch-yaw [rad], unit axis
  double lower = 0, upper = 0;     ///< position limits [rad]
  double velocity = 0;             ///< [rad/s]
  double acceleration = 0;         ///< [rad/s^2]
  double jerk = 0;                 ///< [rad/s^3]
  double effort = 0;               ///< [N m]
};

struct ShapeSpec {
  enum class Type { kCapsule, kCylinder, kBox, kSphere, kMesh };
  Type type = Type::kSphere;
  std::array<double, 3> from{}, to{};  ///< capsule/cylinder axis end points [m]
  std::array<double, 3> pos{};         ///< box/sphere center, mesh origin [m]
  std::array<double, 3> half{};        ///< box half sizes [m]
  std::array<double, 4> quat{1, 0, 0, 0};  ///< box or mesh orientation (w, x, y, z)
  double radius = 0;                   ///< [m]
  std::string mesh;                    ///< mesh: its STL or OBJ file (absolute); it collides as its convex hull
  std::array<double, 3> scale{1, 1, 1};  ///< mesh: scale of its vertices
};

struct LinkSpec {
  std::string name;
  double mass = 0;  ///< [kg]
  std::vector<ShapeSpec> shapes;  ///< in the link frame
  /// A description's own inertia (a URDF's); without it, the writers spread the mass uniformly over
  /// the shapes.
  bool has_inertia = false;
  std::array<double, 3> com{};      ///< [m] in the link frame
  std::array<double, 6> inertia{};  ///< about com, link axes: ixx iyy izz ixy ixz iyz [kg m^2]
};

/// A two-finger parallel gripper: a hand body on the flange (z along the approach), two fingers
/// sliding along the hand's +y and -y, and the TCP between the fingertips.
struct GripperSpec {
  std::string file;         ///< where it was read from
  std::string name;
  double travel = 0.04;     ///< [m] per finger
  double max_force = 70;    ///< [N] per finger
  double velocity = 0.2;    ///< [m/s]
  double finger_z = 0.0584; ///< [m] finger joint origin along hand z
  double pad_friction = 1.5;
  double tcp_offset = 0.1; ///< [m] TCP along hand z
  std::string tcp;          ///< the TCP's name (a URDF link, an MJCF site)
  std::array<std::string, 2> finger_joints;  ///< +y finger's, -y finger's
  LinkSpec hand;
  std::array<LinkSpec, 2> fingers;
};

struct RobotSpec {
  std::string file;  ///< where it was read from (an arm YAML, or a URDF)
  std::string sidecar;  ///< a URDF's companion YAML (<file>.yaml), when there is one
  std::string name, base_link;
  std::string tip_link;           ///< the gripper's TCP
  std::vector<JointSpec> joints;  ///< arm joints, base to tip
  double flange_d = 0;            ///< [m] flange along the last joint's z
  double hand_yaw = 0;            ///< [rad] the gripper's mounting angle about the flange z
  /// Where the gripper's hand sits in the last joint's frame: (0, 0, flange_d) and (0, 0, hand_yaw)
  /// for an arm written in DH; a URDF's fixed joints to its flange link, then flange_d and hand_yaw.
  std::array<double, 3> flange_xyz{}, flange_rpy{};  ///< [m], roll-pitch-yaw [rad]
  double tcp_offset = 0;          ///< [m] the gripper's TCP past the flange
  /// The closed-form IK the robot declares ("panda", "ur"; empty: none). The solver checks the
  /// kinematic structure when it is made, so a wrong declaration is an input error.
  std::string analytic_ik;
  std::vector<double> home;  ///< [rad], dim joints.size()
  /// Where home came from: "yaml" (an arm YAML or a companion's home), "keyframe" (an MJCF's
  /// keyframe 'home'), "computed" (above the bin, by the campaign), or "" (unsaid: each joint at
  /// 0, clamped into its limits, for the campaign to replace).
  std::string home_source;
  /// The robot file's link the gripper mounts on, and how it was chosen.
  std::string flange_link, flange_choice;
  /// What loading changed of the robot file, said to the user (a shipped hand left out, an
  /// inertia balanced).
  std::vector<std::string> notes;
  double damping = 0, armature = 0;
  GripperSpec gripper;
  /// Links in order: base, one per joint, then the gripper's hand, +y finger, -y finger.
  std::vector<LinkSpec> links;
  /// The names every link and joint of the arm and gripper take (to check a robot's names stay
  /// out of the harness's code).
  std::vector<std::string> names() const;

  std::string directory() const;
  std::string mjcfPath() const;  ///< <dir>/<name>.xml
  std::string urdfPath() const;  ///< <dir>/<name>.urdf
};

/// Reads and validates a robot — an arm YAML, or a URDF (`.urdf`) with an optional companion YAML
/// beside it (`<file>.yaml`: what a URDF lacks) — and mounts a gripper: `gripper_yaml`, or when
/// empty the one the robot's file names (relative to that file). Throws InputError naming
/// file:line and what was expected.
RobotSpec loadRobotSpec(const std::string& path, const std::string& gripper_yaml = "");
/// The URDF branch of loadRobotSpec (robot/urdf_robot.cc).
RobotSpec loadUrdfRobotSpec(const std::string& urdf_path, const std::string& gripper_yaml);
/// Reads and validates a gripper YAML.
GripperSpec loadGripperSpec(const std::string& path);

}  // namespace mm
