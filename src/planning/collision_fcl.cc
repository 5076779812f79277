#include <fcl/fcl.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <map>
#include <mutex>

#include "core/error.h"
#include "planning/collision.h"

namespace mm {
namespace {

using Geom = std::shared_ptr<fcl::CollisionGeometryd>;

fcl::Transform3d toFcl(const Pose& T) {
  fcl::Transform3d X = fcl::Transform3d::Identity();
  X.linear() = T.linear();
  X.translation() = T.translation();
  return X;
}

struct Body {
  Geom geom;
  Pose T_local = Pose::Identity();  // shape in its link (robot) or world (obstacle)
  int link = -1;
  double bound = 0;  // bounding sphere radius about the shape origin
  std::string name;
};

// A hull grown as the boxes are (sizes grown, not rounded): the hull of every vertex moved to the
// corners of a cube of half side `pad` around it, the Minkowski sum with that cube. Kept per hull
// and padding.
std::shared_ptr<const ConvexHull> paddedHull(const std::shared_ptr<const ConvexHull>& hull, double pad) {
  if (pad <= 0) return hull;
  static std::mutex mutex;
  static std::map<std::pair<const ConvexHull*, double>, std::shared_ptr<const ConvexHull>> cache;
  std::lock_guard<std::mutex> lock(mutex);
  auto& slot = cache[{hull.get(), pad}];
  if (!slot) {
    std::vector<Vec3> points;
    for (const Vec3& v : hull->vertices)
      for (int k = 0; k < 8; ++k) points.push_back(v + pad * Vec3((k & 1) ? 1 : -1, (k & 2) ? 1 : -1, (k & 4) ? 1 : -1));
    slot = std::make_shared<const ConvexHull>(convexHull(points, "a padded collision mesh"));
  }
  return slot;
}

std::shared_ptr<fcl::CollisionGeometryd> convexGeometry(const ConvexHull& h) {
  auto vertices = std::make_shared<std::vector<fcl::Vector3d>>();
  for (const Vec3& v : h.vertices) vertices->push_back(v);
  auto faces = std::make_shared<std::vector<int>>();
  for (const auto& f : h.faces) faces->insert(faces->end(), {3, f[0], f[1], f[2]});
  return std::make_shared<fcl::Convexd>(vertices, static_cast<int>(h.faces.size()), faces);
}

Body robotShape(const CollisionShape& s, double pad) {
  Body b;
  b.link = s.link;
  b.T_local = s.T_link_shape;
  switch (s.type) {
    case CollisionShape::Type::kSphere:
      b.geom = std::make_shared<fcl::Sphered>(s.size.x() + pad);
      b.bound = s.size.x() + pad;
      break;
    case CollisionShape::Type::kCylinder:
      b.geom = std::make_shared<fcl::Cylinderd>(s.size.x() + pad, s.size.y() + 2 * pad);
      b.bound = std::hypot(s.size.x() + pad, s.size.y() / 2 + pad);
      break;
    case CollisionShape::Type::kBox: {
      const Vec3 full = s.size + Vec3::Constant(2 * pad);
      b.geom = std::make_shared<fcl::Boxd>(full);
      b.bound = full.norm() / 2;
      break;
    }
    case CollisionShape::Type::kConvex: {
      const auto hull = paddedHull(s.hull, pad);
      b.geom = convexGeometry(*hull);
      b.bound = 0;
      for (const Vec3& v : hull->vertices) b.bound = std::max(b.bound, v.norm());
      break;
    }
  }
  return b;
}

Body obstacleShape(const Obstacle& o) {
  Body b;
  b.T_local = o.T_world;
  b.name = o.name;
  switch (o.type) {
    case Obstacle::Type::kBox:
      b.geom = std::make_shared<fcl::Boxd>(2 * o.size);
      b.bound = o.size.norm();
      break;
    case Obstacle::Type::kSphere:
      b.geom = std::make_shared<fcl::Sphered>(o.size.x());
      b.bound = o.size.x();
      break;
    case Obstacle::Type::kCylinder:
      b.geom = std::make_shared<fcl::Cylinderd>(o.size.x(), 2 * o.size.y());
      b.bound = std::hypot(o.size.x(), o.size.y());
      break;
    case Obstacle::Type::kCapsule:
      b.geom = std::make_shared<fcl::Capsuled>(o.size.x(), 2 * o.size.y());
      b.bound = o.size.x() + o.size.y();
      break;
  }
  return b;
}

bool collide(const Body& a, const Pose& Ta, const Body& b, const Pose& Tb) {
  if ((Ta.translation() - Tb.translation()).norm() > a.bound + b.bound) return false;
  fcl::CollisionRequestd req;
  fcl::CollisionResultd res;
  fcl::collide(a.geom.get(), toFcl(Ta), b.geom.get(), toFcl(Tb), req, res);
  return res.isCollision();
}

class FclChecker final : public GeometricChecker {
 public:
  FclChecker(const RobotModel& robot, const PlanningScene& scene, double pad) : GeometricChecker(robot), scene_(scene) {
    for (const auto& s : robot.collisionShapes()) {
      padded_.push_back(robotShape(s, pad));
      bare_.push_back(robotShape(s, 0.0));
    }
    for (const auto& o : scene.obstacles) {
      if (std::find(scene.ignore.begin(), scene.ignore.end(), o.name) != scene.ignore.end()) continue;
      world_.push_back(obstacleShape(o));
    }
    hand_ = robot.handLink();
    MM_DEMAND(hand_ >= 0);
    const double apad = std::isnan(scene.attached_padding) ? pad : scene.attached_padding;
    for (const PlanningScene::AttachedBox& a : attachedBoxes(scene)) {
      Obstacle box;
      box.size = (a.half + Vec3::Constant(apad)).cwiseMax(1e-3);
      Body& held = attached_.emplace_back(obstacleShape(box));
      held.name = "held object";
      // Pose relative to the hand link: T_hand_tcp * T_tcp_box.
      const Pose T_hand_tcp = makePose(Vec3(0, 0, robot.spec().tcp_offset), Mat3::Identity());
      held.T_local = T_hand_tcp * a.T_tcp_box;
    }
    // Self-collision: every primitive pair of the checked link pairs.
    for (const auto& [la, lb] : selfCollisionLinkPairs(robot, scene.finger_opening))
      for (size_t i = 0; i < bare_.size(); ++i)
        for (size_t j = 0; j < bare_.size(); ++j)
          if (bare_[i].link == la && bare_[j].link == lb) self_pairs_.push_back({static_cast<int>(i), static_cast<int>(j)});
  }

  bool collisionFree(const VecX& q) override {
    robot_.linkPoses(q, scene_.finger_opening, T_);
    const auto& links = robot_.links();
    for (size_t i = 0; i < padded_.size(); ++i) {
      const Body& b = padded_[i];
      if (links[b.link].frame == 0) continue;  // the base stands on the table
      const Pose Tb = T_[b.link] * b.T_local;
      for (const Body& o : world_)
        if (collide(b, Tb, o, o.T_local)) {
          last_ = links[b.link].name + " / " + o.name;
          return false;
        }
    }
    for (const Body& held : attached_) {
      const Pose Ta = T_[hand_] * held.T_local;
      for (const Body& o : world_)
        if (std::find(scene_.attached_ignore.begin(), scene_.attached_ignore.end(), o.name) == scene_.attached_ignore.end() &&
            collide(held, Ta, o, o.T_local)) {
          last_ = "held object / " + o.name;
          return false;
        }
    }
    for (const auto& [i, j] : self_pairs_) {
      const Body &a = bare_[i], &b = bare_[j];
      if (collide(a, T_[a.link] * a.T_local, b, T_[b.link] * b.T_local)) {
        last_ = links[a.link].name + " / " + links[b.link].name;
        return false;
      }
    }
    return true;
  }

 private:
  PlanningScene scene_;
  std::vector<Body> padded_, bare_, world_;
  std::vector<Body> attached_;
  int hand_ = -1;
  std::vector<std::pair<int, int>> self_pairs_;
  std::vector<Pose> T_;
};

}  // namespace

std::vector<std::pair<int, int>> selfCollisionLinkPairs(const RobotModel& robot, double finger_opening) {
  const auto& links = robot.links();
  std::vector<Pose> T;
  robot.linkPoses(robot.home(), finger_opening, T);
  std::vector<Body> bare;
  for (const auto& s : robot.collisionShapes()) bare.push_back(robotShape(s, 0.0));
  std::vector<std::pair<int, int>> out;
  for (size_t a = 0; a < links.size(); ++a)
    for (size_t b = a + 1; b < links.size(); ++b) {
      if (std::abs(links[a].frame - links[b].frame) <= 1) continue;
      bool touch = false;
      for (const Body& x : bare)
        for (const Body& y : bare)
          if (!touch && x.link == static_cast<int>(a) && y.link == static_cast<int>(b))
            touch = collide(x, T[a] * x.T_local, y, T[b] * y.T_local);
      if (!touch) out.push_back({static_cast<int>(a), static_cast<int>(b)});
    }
  return out;
}

double clearance(const RobotModel& robot, const PlanningScene& scene, const VecX& q) {
  std::vector<Pose> T;
  robot.linkPoses(q, scene.finger_opening, T);
  std::vector<Body> world;
  for (const auto& o : scene.obstacles)
    if (std::find(scene.ignore.begin(), scene.ignore.end(), o.name) == scene.ignore.end()) world.push_back(obstacleShape(o));
  double best = INFINITY;
  for (const auto& s : robot.collisionShapes()) {
    if (robot.links()[s.link].frame == 0) continue;
    const Body b = robotShape(s, 0.0);
    for (const Body& o : world) {
      fcl::DistanceRequestd req;
      fcl::DistanceResultd res;
      fcl::distance(b.geom.get(), toFcl(T[s.link] * b.T_local), o.geom.get(), toFcl(o.T_local), req, res);
      best = std::min(best, std::max(0.0, res.min_distance));
    }
  }
  return best;
}

PieceBox pieceBox(const ConvexPiece& piece) {
  Vec3 mean = Vec3::Zero();
  for (const Vec3& v : piece.vertices) mean += v;
  mean /= static_cast<double>(std::max<size_t>(1, piece.vertices.size()));
  Mat3 C = Mat3::Zero();
  for (const Vec3& v : piece.vertices) C += (v - mean) * (v - mean).transpose();
  Mat3 R = Eigen::SelfAdjointEigenSolver<Mat3>(C).eigenvectors();
  if (R.determinant() < 0) R.col(0) = -R.col(0);
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  for (const Vec3& v : piece.vertices) {
    const Vec3 q = R.transpose() * (v - mean);
    lo = lo.cwiseMin(q), hi = hi.cwiseMax(q);
  }
  return {makePose(mean + R * ((lo + hi) / 2), R), (hi - lo) / 2};
}

void attachObject(PlanningScene& scene, const Vec3& half, const Pose& T_tcp_object,
                  const std::shared_ptr<const std::vector<ConvexPiece>>& pieces) {
  scene.has_attached = true;
  scene.attached_half = half;
  scene.T_tcp_attached = T_tcp_object;
  scene.attached_boxes.clear();
  if (!pieces) return;
  for (const ConvexPiece& piece : *pieces) {
    const PieceBox b = pieceBox(piece);
    scene.attached_boxes.push_back({T_tcp_object * b.T_object_box, b.half});
  }
}

std::vector<PlanningScene::AttachedBox> attachedBoxes(const PlanningScene& scene) {
  if (!scene.has_attached) return {};
  if (!scene.attached_boxes.empty()) return scene.attached_boxes;
  return {{scene.T_tcp_attached, scene.attached_half}};
}

const std::vector<std::string>& checkerNames() {
  static const std::vector<std::string> names = {"spheres", "spheres+fcl", "fcl"};
  return names;
}

std::unique_ptr<CollisionChecker> makeChecker(const std::string& name, const RobotModel& robot, const PlanningScene& scene,
                                              double padding) {
  if (name == "fcl") return makeFclChecker(robot, scene, padding);
  if (name == "spheres") return makeSphereChecker(robot, scene, padding, false);
  if (name == "spheres+fcl") return makeSphereChecker(robot, scene, padding, true);
  throw InputError("collision checker '" + name + "'", "unknown checker (expected fcl, spheres or spheres+fcl)");
}

std::unique_ptr<CollisionChecker> makeFclChecker(const RobotModel& robot, const PlanningScene& scene, double padding) {
  return std::make_unique<FclChecker>(robot, scene, padding);
}

}  // namespace mm
