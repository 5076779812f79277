// Grasp candidates for a parallel gripper on boxes and cylinders, scored, best first.
//   top-down: the TCP's z pointing down (or into a tilted box's upper face), the fingers closing
//             across a pair of vertical faces (a box) or through the axis at sampled yaws (an
//             upright cylinder: any yaw is the same grasp of the object);
//   side:     for tall upright objects, the TCP's z horizontal into the object, the fingers closing
//             horizontally across it, as low as the hand can go without sweeping over a
//             neighbour's or a wall's top (the lower, the nearer the centre of mass).
// Each candidate is scored — force closure (the pads' contact normals against the line between
// the contacts, inside the friction cones), the pad area the object covers, the torque arm from the
// centre of mass to the grasp axis, the open fingers' clearance — and a candidate out of force
// closure is kept, last, with the reason it is dropped, so that the filter records it.
#pragma once
#include <string>
#include <vector>

#include "core/config.h"
#include "core/geometry.h"

namespace mm {

struct GraspOptions {
  /// Keys depth, yaw_offsets, side_grasps, side_min_height, torque_weight, tilt_weight (section "grasp").
  void declare(ConfigArchive& a);
  double max_opening = 0.08;      ///< [m] full stroke of the gripper
  double width_margin = 0.01;     ///< [m] the object must be this much narrower than the stroke
  double depth = 0.0;             ///< [m] TCP above the object's center (positive = higher)
  double finger_reach = 0.06;     ///< [m] half span of the open fingers from the TCP (for clearance)
  double clearance_weight = 10.0; ///< score per metre of clearance (capped at 5 cm)
  /// Yaw samples [rad] around each face-aligned grasp: the aligned one (0) and offsets from it.
  /// The penalty per radian of offset is large enough that every aligned candidate is tried
  /// before any misaligned one (which relies on the pads turning the object as they close).
  std::vector<double> yaw_offsets = {0.0, 0.15, -0.15, 0.3, -0.3};
  double offset_penalty = 100.0;
  // The gripper, in the TCP frame (z along the approach, the fingers closing along y): from its
  // description (task/ fills these from the robot's gripper).
  double friction = 1.5;          ///< the pads' Coulomb coefficient
  double pad_half_width = 0.0105; ///< [m] pad half extent along the TCP's x
  double pad_z_min = -0.045, pad_z_max = 0.009;  ///< [m] pad extent along the TCP's z (tip: max)
  double hand_back = 0.0414;      ///< [m] the hand body's nearest point behind the TCP, along -z
  double hand_half_thickness = 0.031;  ///< [m] the hand body's half extent along the TCP's x
  double hand_half_width = 0.102;      ///< [m] the hand body's half extent along the TCP's y
  double finger_thickness = 0.018;     ///< [m] a finger's extent along the TCP's y (closing direction)
  double approach_distance = 0.1;      ///< [m] pre-grasp back from the grasp, along the approach
  // Side grasps and scoring.
  bool side_grasps = true;
  double side_min_height = 0.09;  ///< [m] upright objects at least this tall also get side grasps
  int side_azimuths = 8;          ///< approach directions sampled around a cylinder
  double torque_weight = 40.0;    ///< score per metre of torque arm
  double tilt_weight = 0.5;       ///< score per radian of the hand's tilt from pointing down
  double closure_weight = 0.2;    ///< score per radian of force-closure margin
  double area_weight = 0.5;       ///< score per unit of pad fraction covered
};

/// kCloud: a model-free grasp from the depth image's points (grasp/cloud_grasps.h).
/// kCloud: from the camera's points (grasp/cloud_grasps.h); kExternal: from an external component
/// (the user's detector). Both are a TCP pose and the object's width across the pads, no model.
enum class GraspType { kTopDown, kSide, kCloud, kExternal };
inline const char* graspTypeName(GraspType t) {
  return t == GraspType::kSide ? "side" : t == GraspType::kCloud ? "cloud" : t == GraspType::kExternal ? "external" : "top_down";
}
/// A grasp from observed points with no model (kCloud, kExternal): its width is what the pads close on.
inline bool fromPoints(GraspType t) { return t == GraspType::kCloud || t == GraspType::kExternal; }

/// A TCP's orientation turned half a turn about its z (the approach): x and y reversed. For a
/// parallel gripper it is the same grasp with the wrist the other way round.
inline Mat3 halfTurnAboutApproach(Mat3 R_world_tcp) {
  R_world_tcp.col(0) *= -1;
  R_world_tcp.col(1) *= -1;
  return R_world_tcp;
}

struct GraspCandidate {
  Pose T_world_tcp = Pose::Identity();
  GraspType type = GraspType::kTopDown;
  double yaw = 0;    ///< [rad] TCP yaw (TCP z points down); side grasps: the approach's azimuth
  double width = 0;  ///< [m] object width across the fingers
  double clearance = 0;  ///< [m] to the nearest neighbour along the finger direction
  double closure_margin = 0;  ///< [rad] atan(friction) minus the larger contact angle; > 0: force closure
  double contact_area = 0;    ///< [m^2] pad area the object covers (both pads alike)
  double torque_arm = 0;      ///< [m] centre of mass to the grasp axis
  double score = 0;
  Vec3 approach = Vec3::UnitZ();  ///< from the grasp towards the pre-grasp (straight up, the tilted top face's normal, or horizontal)
  std::string rejected;       ///< why the scorer drops it ("": kept)
};

/// Force closure of two frictional point contacts (a parallel jaw): p1, p2 the contacts, n1, n2
/// the surface normals pointing into the object. The grasp is in force closure iff the segment
/// p1-p2 lies strictly inside both friction cones (Nguyen 1988, "Constructing force-closure
/// grasps"). Returns atan(mu) minus the larger angle between the segment and a normal: positive
/// in closure, its size the margin.
double forceClosureMargin(const Vec3& p1, const Vec3& n1, const Vec3& p2, const Vec3& n2, double mu);

/// Candidates for `target`, best first (those out of force closure last, `rejected` set).
/// `preferred_yaw` is the top-down TCP yaw needing no wrist rotation; `robot_base` where the arm
/// stands (side grasps approach from its side first); `neighbours` the other objects and obstacles.
/// A box tilted 15 to 50 degrees (leaning on a neighbour or a wall) is grasped across its upper
/// face's sides, approached along that face's normal; one tilted more, a tilted cylinder, or one
/// too wide gives no candidate.
std::vector<GraspCandidate> graspCandidates(const ObjectState& target, double preferred_yaw, const Vec3& robot_base,
                                            const std::vector<Obstacle>& neighbours, const GraspOptions& options);

/// Where the line p + t y enters and leaves the object (t1 < t2), with the outward normals there;
/// false when it misses.
bool lineThroughObject(const ObjectState& o, const Vec3& p, const Vec3& y, double& t1, double& t2, Vec3& n1, Vec3& n2);

/// The TCP orientation pointing down with yaw psi: Rz(psi) * Rx(pi).
Mat3 topDownRotation(double psi);

}  // namespace mm
