// RobotModel: an immutable serial arm with a parallel gripper, shared by every worker.
// Kinematic tree and collision geometry come from the URDF (urdfdom); limits, home and gripper
// numbers come from the arm's and the gripper's YAML (the source both descriptions are written from).
#pragma once
#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "core/pose.h"
#include "robot/mesh.h"
#include "robot/robot_spec.h"

namespace mm {

using VecX = Eigen::VectorXd;
using Jacobian = Eigen::Matrix<double, 6, Eigen::Dynamic>;

/// A collision primitive attached to a link.
struct CollisionShape {
  enum class Type { kSphere, kCylinder, kBox, kConvex };
  Type type = Type::kSphere;
  Vec3 size = Vec3::Zero();  ///< sphere: (r,-,-); cylinder: (r, length, -) along z; box: full sizes [m]
  std::shared_ptr<const ConvexHull> hull;  ///< convex: a mesh's hull, in the shape frame
  int link = 0;              ///< index into RobotModel::links()
  Pose T_link_shape = Pose::Identity();
};

/// Where a link sits: frame f (0 = base, k = after arm joint k), then a fixed transform, then an
/// optional gripper (prismatic) joint whose value is the finger opening.
struct LinkInfo {
  std::string name;
  int frame = 0;
  Pose T_frame_joint = Pose::Identity();  ///< up to the link (or to its gripper joint)
  Vec3 finger_axis = Vec3::Zero();        ///< non-zero for a finger: the opening moves it along this
};

class RobotModel {
 public:
  /// Loads an arm's YAML with a gripper mounted on its flange (`gripper_yaml`, or the arm's
  /// default) and builds the kinematic tree from their URDF. Throws InputError on bad files.
  static RobotModel load(const std::string& spec_yaml, const std::string& gripper_yaml = "");
  /// The model of a robot already read (e.g. from an MJCF file, by sim/mjcf_robot.h).
  static RobotModel fromSpec(RobotSpec spec);
  /// Index into links() of the gripper's hand, and of its fingers (+y, -y).
  int handLink() const { return hand_link_; }
  int fingerLink(int k) const { return finger_link_[k]; }

  int dof() const { return static_cast<int>(axis_.size()); }
  const RobotSpec& spec() const { return spec_; }
  const VecX& lower() const { return lower_; }    ///< [rad] (dim dof)
  const VecX& upper() const { return upper_; }    ///< [rad]
  const VecX& vmax() const { return vmax_; }      ///< [rad/s]
  const VecX& amax() const { return amax_; }      ///< [rad/s^2]
  const VecX& jmax() const { return jmax_; }      ///< [rad/s^3]
  const VecX& home() const { return home_; }      ///< [rad]
  const std::vector<std::string>& jointNames() const { return joint_names_; }
  bool withinLimits(const VecX& q, double margin = 0.0) const;

  /// T_base_tcp for joint configuration q (dim dof) [rad].
  Pose fk(const VecX& q) const;
  /// Frames 0..dof: T_base_frame[k] is the frame after joint k (0 = base). Resizes the output.
  void frames(const VecX& q, std::vector<Pose>& T_base_frame) const;
  /// Pose of every link (index as links()) for q and a finger opening [m] per finger.
  void linkPoses(const VecX& q, double finger_opening, std::vector<Pose>& T_base_link) const;
  /// Geometric Jacobian of the TCP in the base frame: rows (v; w), dim 6 x dof.
  void jacobian(const VecX& q, Jacobian& J) const;

  /// [m] How far the closed fingers' collision shapes reach past the TCP along its approach (z) axis.
  double fingertipBelowTcp() const;

  const std::vector<LinkInfo>& links() const { return links_; }
  const std::vector<CollisionShape>& collisionShapes() const { return shapes_; }
  int linkIndex(const std::string& name) const;  ///< -1 if absent
  const Pose& T_flange_tcp() const { return T_last_tcp_; }
  /// A copy whose tip is the flange (the last joint's frame) instead of the TCP, for comparisons
  /// with IK figures published for the flange.
  RobotModel withFlangeTip() const {
    RobotModel m = *this;
    m.T_last_tcp_ = Pose::Identity();
    return m;
  }
  /// The chain as FK uses it: frame_k = frame_{k-1} * jointOrigin(k) * Rot(jointAxis(k), q_k),
  /// then T_base_tcp = frame_dof * T_flange_tcp().
  const Pose& jointOrigin(int k) const { return T_pre_[k]; }
  const Vec3& jointAxis(int k) const { return axis_[k]; }

 private:
  RobotSpec spec_;
  std::vector<std::string> joint_names_;
  std::vector<Pose> T_pre_;   ///< fixed transform from frame k-1 to joint k's origin
  std::vector<Vec3> axis_;    ///< joint axis in its own frame
  Pose T_last_tcp_ = Pose::Identity();
  VecX lower_, upper_, vmax_, amax_, jmax_, home_;
  std::vector<LinkInfo> links_;
  std::vector<CollisionShape> shapes_;
  int hand_link_ = -1;
  std::array<int, 2> finger_link_{-1, -1};
};

}  // namespace mm
