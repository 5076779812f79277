// Grasp candidates for a parallel gripper: top-down on a box-shaped object, both finger
// orientations about each pair of faces, ranked by wrist rotation and finger clearance.
#pragma once
#include <vector>
#include <string>

#include "core/config.h"
#include "core/geometry.h"

namespace mm {

struct GraspOptions {
  /// Keys depth, yaw_offsets (section "grasp").
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
};

struct GraspCandidate {
  Pose T_world_tcp = Pose::Identity();
  double yaw = 0;    ///< [rad] TCP yaw (TCP z points down)
  double width = 0;  ///< [m] object width across the fingers
  double clearance = 0;  ///< [m] to the nearest neighbour along the finger direction
  double score = 0;
  Vec3 approach = Vec3::UnitZ();  ///< from the grasp towards the pre-grasp (straight up, or the tilted top face's normal)
};

/// Candidates for `target`, best first: for each pair of vertical faces, both finger
/// orientations, at each sampled yaw offset. `preferred_yaw` is the TCP yaw needing no wrist rotation;
/// `neighbours` are the other objects and obstacles the open fingers should keep clear of.
/// An object tilted 15 to 50 degrees (leaning on a neighbour or a wall) is grasped across its
/// upper face's sides, approached along that face's normal; one tilted more, or too wide, gives no
/// candidate.
std::vector<GraspCandidate> topDownGrasps(const ObjectState& target, double preferred_yaw,
                                          const std::vector<Obstacle>& neighbours, const GraspOptions& options);

/// The TCP orientation pointing down with yaw psi: Rz(psi) * Rx(pi).
Mat3 topDownRotation(double psi);

}  // namespace mm
