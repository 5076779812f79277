// Internal to robot/ and sim/: building an arm from a description file (a URDF, an MJCF) and
// its companion YAML (<file>.yaml: what such files lack). The description's reader fills joints
// (origin, axis, limits) and links (shapes, inertia); this finishes the arm alike for every format.
#pragma once
#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

#include "core/pose.h"
#include "robot/robot_spec.h"
#include "robot/spec_reader.h"

namespace mm::arm_builder {

/// The companion YAML of `description` (`description + ".yaml"`; absent: an empty map), its keys
/// checked against the common ones and `extra_keys`.
struct Companion {
  std::string path;
  YAML::Node y;
  spec_io::Reader r;
  double number(const char* key, double fallback) const { return y[key] ? r.number(y, key) : fallback; }
  /// One value for all `n` joints, or a list of n; `fallback` when absent.
  std::vector<double> perJoint(const char* key, size_t n, double fallback, bool positive) const;
};
Companion loadCompanion(const std::string& description, const char* format, const std::vector<std::string>& extra_keys = {});

/// Mass properties in a link's frame, merged as links are fixed together.
struct Inertia {
  double mass = 0;
  Vec3 com = Vec3::Zero();
  Mat3 I = Mat3::Zero();  ///< about com
};
/// Adds `b`, placed by `T` in the frame of `a`.
void addInertia(Inertia& a, const Inertia& b, const Pose& T);

std::array<double, 3> arr(const Vec3& v);
/// URDF's roll-pitch-yaw (R = Rz(yaw) Ry(pitch) Rx(roll)).
std::array<double, 3> rpyOf(const Mat3& R);
/// Sets `dh` (and a, d, alpha) when the joint's origin and axis have the modified-DH form.
void recognizeDh(JointSpec& j);
/// A link's shapes and inertia into `s.links`: capsules recognized (a cylinder with spheres of its
/// radius on both ends), a mass and a shape required. `description` names the file in errors.
/// The base (the first link) may have neither: it is welded to the world. A link without mass
/// takes the companion's default_link_mass, if any; principal moments violating A + B >= C are
/// balanced (MuJoCo's balanceinertia), said in `s.notes`.
void addLink(RobotSpec& s, LinkSpec link, const Inertia& inertia, const std::string& description, const Companion& c);
/// Finishes the arm: flange (`T_last_flange`, then the companion's flange_d and hand_yaw), the
/// per-joint limits the description lacks, home (the companion's, else `file_home` when the
/// description has one — an MJCF keyframe — else unsaid), damping, armature, analytic_ik, and the
/// gripper (`gripper_yaml`, else the companion's).
void finishArm(RobotSpec& s, const Companion& c, const Pose& T_last_flange, const std::string& gripper_yaml,
               const std::string& description, const std::vector<double>& file_home = {});
/// The tool-frame rule: the rank of a frame's name as a flange (0 tool0, 1 flange, 2 *_ee*,
/// 3 end_effector*), or -1 for a name that is none of them.
int toolFrameRank(const std::string& name);

}  // namespace mm::arm_builder
