// Collision checking of robot configurations against the planning scene (the world as the planner
// knows it: static obstacles exported from the scene plus perceived objects), padded, and against
// the robot itself. FCL is the reference implementation; FCL headers stay in collision_fcl.cc.
#pragma once
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/geometry.h"
#include "robot/robot_model.h"

namespace mm {

/// The world as the planner knows it (MoveIt's PlanningScene, reduced to what we need).
struct PlanningScene {
  std::vector<Obstacle> obstacles;
  /// An object held in the hand: a box with half sizes `half`, at T_tcp_object from the TCP.
  bool has_attached = false;
  Vec3 attached_half = Vec3::Zero();
  Pose T_tcp_attached = Pose::Identity();
  /// The held object as several boxes in the TCP frame (a mesh object's convex pieces, each its
  /// box): when not empty, these are checked instead of attached_half at T_tcp_attached.
  struct AttachedBox {
    Pose T_tcp_box = Pose::Identity();
    Vec3 half = Vec3::Zero();
  };
  std::vector<AttachedBox> attached_boxes;
  /// Obstacles the held object is not checked against (but the robot is): its support as it is
  /// lifted straight off it.
  std::vector<std::string> attached_ignore;
  /// Padding of the held object [m]; NaN = the checker's padding. Negative = a contact tolerance,
  /// for lifting off and setting down on a support surface.
  double attached_padding = std::numeric_limits<double>::quiet_NaN();
  double finger_opening = 0.04;  ///< [m] per finger, for the finger shapes
  /// Names of obstacles not to check (e.g. the object being grasped during approach).
  std::vector<std::string> ignore;
};

/// A convex piece's box in its object's frame: along the principal axes of its vertices (an
/// irregular prism's, a pebble's box hugs it far closer than one along the object's axes).
struct PieceBox {
  Pose T_object_box = Pose::Identity();
  Vec3 half = Vec3::Zero();
};
PieceBox pieceBox(const ConvexPiece& piece);

/// Attaches a held object to `scene`: its box (`half` at T_tcp_object), and, for a mesh object of
/// several convex pieces, one box per piece (each in the object's frame), so that an L or a ring
/// in the hand is not checked as its whole bounding box.
void attachObject(PlanningScene& scene, const Vec3& half, const Pose& T_tcp_object,
                  const std::shared_ptr<const std::vector<ConvexPiece>>& pieces);

/// The boxes the checkers take the held object as: attached_boxes, or the one box.
std::vector<PlanningScene::AttachedBox> attachedBoxes(const PlanningScene& scene);

class CollisionChecker {
 public:
  virtual ~CollisionChecker() = default;
  /// True when q (dim dof) is within joint limits and collision-free.
  virtual bool isValid(const VecX& q) = 0;
  /// Name of the first colliding pair found by the last invalid isValid() call.
  virtual std::string lastCollision() const = 0;
  long checks() const { return checks_; }

 protected:
  long checks_ = 0;
};

/// Base of the geometric checkers: counts the check and applies the joint limits (one rule for
/// all), then asks the subclass about geometry.
class GeometricChecker : public CollisionChecker {
 public:
  explicit GeometricChecker(const RobotModel& robot) : robot_(robot) {}
  bool isValid(const VecX& q) final {
    ++checks_;
    if (!robot_.withinLimits(q)) {
      last_ = "joint limits";
      return false;
    }
    return collisionFree(q);
  }
  std::string lastCollision() const override { return last_; }

 protected:
  /// q is within the limits; true when it is collision-free (else set last_).
  virtual bool collisionFree(const VecX& q) = 0;
  const RobotModel& robot_;
  std::string last_;
};

/// FCL checker. `padding` [m] inflates the robot's shapes against the world (not against itself).
/// Self-collision skips pairs of links on the same or neighbouring frames and pairs that touch in
/// the home configuration (as MoveIt's setup assistant's "adjacent" and "default" rules).
std::unique_ptr<CollisionChecker> makeFclChecker(const RobotModel& robot, const PlanningScene& scene, double padding);

/// The link pairs checked for self-collision (MoveIt's allowed-collision rules, link level): links
/// more than one frame apart in the chain whose primitives do not touch at the home configuration
/// (with the fingers at `finger_opening`). Both checkers use this one rule.
std::vector<std::pair<int, int>> selfCollisionLinkPairs(const RobotModel& robot, double finger_opening);

/// Our fast checker: the robot's primitives covered by spheres (conservative: never free where FCL
/// with the same padding finds a collision), exact sphere-vs-primitive tests, no allocation per
/// check. With `confirm_with_fcl`, a sphere hit is confirmed by FCL, so answers equal FCL's.
std::unique_ptr<CollisionChecker> makeSphereChecker(const RobotModel& robot, const PlanningScene& scene, double padding,
                                                    bool confirm_with_fcl);

/// The robot's collision primitives covered by spheres (the cover the sphere checker uses), with
/// `padding` applied the way FCL pads. For optimizers that need distances and gradients.
struct SphereModel {
  std::vector<int> link;       ///< index into RobotModel::links()
  std::vector<Vec3> local;     ///< center in the link frame [m]
  std::vector<double> radius;  ///< [m]
};
SphereModel coverRobot(const RobotModel& robot, double padding);

/// Signed distance [m] from a sphere (center c, radius r) to the nearest obstacle of the scene
/// (negative inside), and its gradient with respect to c. +inf with a zero gradient if the scene
/// has no obstacle.
double sphereSceneDistance(const PlanningScene& scene, const Vec3& c, double r, Vec3& gradient);

/// Smallest distance [m] between the robot's links (no padding; the base excluded) and the
/// scene's obstacles at q, by FCL; negative depth is reported as 0.
double clearance(const RobotModel& robot, const PlanningScene& scene, const VecX& q);

/// The checkers by name: "spheres", "spheres+fcl", "fcl".
const std::vector<std::string>& checkerNames();
/// "fcl", "spheres" or "spheres+fcl"; throws InputError for another name.
std::unique_ptr<CollisionChecker> makeChecker(const std::string& name, const RobotModel& robot, const PlanningScene& scene,
                                              double padding);

}  // namespace mm
