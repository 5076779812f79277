#include "robot/robot_model.h"

#include <urdf_parser/urdf_parser.h>

#include <filesystem>
#include <functional>
#include <map>
#include <mutex>

#include "core/error.h"
#include "robot/description_writer.h"
#include "robot/urdf_parse.h"

namespace mm {
namespace {

Pose toPose(const urdf::Pose& p) {
  double x, y, z, w;
  p.rotation.getQuaternion(x, y, z, w);
  return makePose(Vec3(p.position.x, p.position.y, p.position.z), Quat(w, x, y, z));
}

}  // namespace

RobotModel RobotModel::load(const std::string& spec_yaml, const std::string& gripper_yaml) {
  return fromSpec(loadRobotSpec(spec_yaml, gripper_yaml));
}

RobotModel RobotModel::fromSpec(RobotSpec spec) {
  RobotModel m;
  m.spec_ = std::move(spec);
  const RobotSpec& s = m.spec_;
  // The kinematic tree as a URDF reader sees it: the URDF written from the arm and its gripper.
  const std::string urdf_path = s.file + " with " + s.gripper.file;
  auto model = parseUrdfText(writeUrdf(s), urdf_path);

  // Chain from tip to base.
  auto tip = model->getLink(s.tip_link);
  if (!tip) throw InputError(urdf_path, "tip link '" + s.tip_link + "' (from " + s.file + ") is not in the URDF");
  std::vector<urdf::JointConstSharedPtr> chain;
  for (auto l = tip; l->name != s.base_link; l = l->getParent()) {
    if (!l->parent_joint) throw InputError(urdf_path, "link '" + s.tip_link + "' is not below base link '" + s.base_link + "'");
    chain.push_back(l->parent_joint);
  }
  std::reverse(chain.begin(), chain.end());

  // Arm joints; fixed joints fold into the transforms.
  Pose T_acc = Pose::Identity();
  std::map<std::string, std::pair<int, Pose>> link_frame;  // link -> (frame, T_frame_link)
  link_frame[s.base_link] = {0, Pose::Identity()};
  for (const auto& j : chain) {
    const Pose T_origin = toPose(j->parent_to_joint_origin_transform);
    if (j->type == urdf::Joint::REVOLUTE || j->type == urdf::Joint::CONTINUOUS) {
      m.T_pre_.push_back(T_acc * T_origin);
      m.axis_.push_back(Vec3(j->axis.x, j->axis.y, j->axis.z).normalized());
      m.joint_names_.push_back(j->name);
      T_acc = Pose::Identity();
      link_frame[j->child_link_name] = {static_cast<int>(m.axis_.size()), Pose::Identity()};
    } else if (j->type == urdf::Joint::FIXED) {
      T_acc = T_acc * T_origin;
      link_frame[j->child_link_name] = {static_cast<int>(m.axis_.size()), T_acc};
    } else {
      throw InputError(urdf_path, "joint '" + j->name + "' on the arm chain must be revolute or fixed");
    }
  }
  m.T_last_tcp_ = T_acc;
  const int n = m.dof();
  if (n != static_cast<int>(s.joints.size()))
    throw InputError(urdf_path, "the chain " + s.base_link + " -> " + s.tip_link + " has " + std::to_string(n) +
                                    " joints, " + s.file + " declares " + std::to_string(s.joints.size()));
  m.lower_.resize(n), m.upper_.resize(n), m.vmax_.resize(n), m.amax_.resize(n), m.jmax_.resize(n), m.home_.resize(n);
  for (int i = 0; i < n; ++i) {
    const JointSpec& js = s.joints[i];
    if (js.name != m.joint_names_[i])
      throw InputError(urdf_path, "joint " + std::to_string(i + 1) + " is '" + m.joint_names_[i] + "', " + s.file +
                                      " expects '" + js.name + "'");
    m.lower_[i] = js.lower, m.upper_[i] = js.upper, m.vmax_[i] = js.velocity;
    m.amax_[i] = js.acceleration, m.jmax_[i] = js.jerk, m.home_[i] = s.home[i];
  }

  // Every link of the tree: arm links, links fixed to them, and gripper fingers (one prismatic joint).
  std::function<void(const urdf::LinkConstSharedPtr&, int, const Pose&, const Vec3&)> visit =
      [&](const urdf::LinkConstSharedPtr& link, int frame, const Pose& T, const Vec3& finger_axis) {
        LinkInfo info{link->name, frame, T, finger_axis};
        const int idx = static_cast<int>(m.links_.size());
        m.links_.push_back(info);
        for (const auto& c : link->collision_array) {
          if (!c || !c->geometry) continue;
          CollisionShape sh;
          sh.link = idx;
          sh.T_link_shape = toPose(c->origin);
          switch (c->geometry->type) {
            case urdf::Geometry::SPHERE:
              sh.type = CollisionShape::Type::kSphere;
              sh.size = Vec3(static_cast<const urdf::Sphere&>(*c->geometry).radius, 0, 0);
              break;
            case urdf::Geometry::CYLINDER: {
              const auto& cy = static_cast<const urdf::Cylinder&>(*c->geometry);
              sh.type = CollisionShape::Type::kCylinder;
              sh.size = Vec3(cy.radius, cy.length, 0);
              break;
            }
            case urdf::Geometry::BOX: {
              const auto& b = static_cast<const urdf::Box&>(*c->geometry);
              sh.type = CollisionShape::Type::kBox;
              sh.size = Vec3(b.dim.x, b.dim.y, b.dim.z);
              break;
            }
            case urdf::Geometry::MESH: {  // collides as its convex hull (MuJoCo's, FCL's, the spheres')
              const auto& me = static_cast<const urdf::Mesh&>(*c->geometry);
              sh.type = CollisionShape::Type::kConvex;
              sh.hull = meshHull(me.filename, Vec3(me.scale.x, me.scale.y, me.scale.z));
              break;
            }
            default:
              throw InputError(urdf_path, "link '" + link->name + "': only sphere, cylinder, box and mesh collision shapes are supported");
          }
          m.shapes_.push_back(sh);
        }
        for (const auto& j : link->child_joints) {
          auto child = model->getLink(j->child_link_name);
          auto it = link_frame.find(child->name);
          if (it != link_frame.end() && it->second.first > frame) {
            visit(child, it->second.first, it->second.second, Vec3::Zero());
          } else if (j->type == urdf::Joint::FIXED) {
            visit(child, frame, T * toPose(j->parent_to_joint_origin_transform), finger_axis);
          } else if (j->type == urdf::Joint::PRISMATIC && finger_axis.isZero()) {
            visit(child, frame, T * toPose(j->parent_to_joint_origin_transform), Vec3(j->axis.x, j->axis.y, j->axis.z));
          } else {
            throw InputError(urdf_path, "joint '" + j->name + "' is neither on the arm chain nor a gripper finger");
          }
        }
      };
  visit(model->getLink(s.base_link), 0, Pose::Identity(), Vec3::Zero());
  m.hand_link_ = m.linkIndex(s.gripper.hand.name);
  for (int k = 0; k < 2; ++k) m.finger_link_[k] = m.linkIndex(s.gripper.fingers[k].name);
  return m;
}

bool RobotModel::withinLimits(const VecX& q, double margin) const {
  for (int i = 0; i < dof(); ++i)
    if (!(q[i] >= lower_[i] + margin && q[i] <= upper_[i] - margin)) return false;
  return true;
}

void RobotModel::frames(const VecX& q, std::vector<Pose>& T) const {
  MM_DEMAND(q.size() == dof());
  T.resize(dof() + 1);
  T[0] = Pose::Identity();
  // Rotation and translation separately (cheaper than 4x4 products), z axes by columns.
  Mat3 R = Mat3::Identity();
  Vec3 p = Vec3::Zero();
  for (int k = 0; k < dof(); ++k) {
    p += R * T_pre_[k].translation();
    R = R * T_pre_[k].linear();
    const double c = std::cos(q[k]), s = std::sin(q[k]);
    if (axis_[k].isApprox(Vec3::UnitZ(), 1e-15)) {
      const Vec3 x = R.col(0), y = R.col(1);
      R.col(0) = c * x + s * y;
      R.col(1) = c * y - s * x;
    } else {
      R = R * Eigen::AngleAxisd(q[k], axis_[k]).toRotationMatrix();
    }
    T[k + 1].linear() = R;
    T[k + 1].translation() = p;
    T[k + 1].makeAffine();
  }
}

Pose RobotModel::fk(const VecX& q) const {
  MM_DEMAND(q.size() == dof());
  Pose T = Pose::Identity();
  for (int k = 0; k < dof(); ++k) {
    Pose R = Pose::Identity();
    R.linear() = Eigen::AngleAxisd(q[k], axis_[k]).toRotationMatrix();
    T = T * T_pre_[k] * R;
  }
  return T * T_last_tcp_;
}

double RobotModel::fingertipBelowTcp() const {
  std::vector<Pose> T;
  linkPoses(home_, 0.0, T);
  const Pose T_tcp = fk(home_);
  const Vec3 z = T_tcp.linear().col(2);
  double reach = 0;
  for (const CollisionShape& s : shapes_) {
    if (links_[s.link].finger_axis.isZero()) continue;
    const Pose T_shape = T[s.link] * s.T_link_shape;
    // The shape's farthest point along z: box corners; a sphere's or cylinder's centre plus extent.
    double far = -1e9;
    if (s.type == CollisionShape::Type::kConvex) {
      for (const Vec3& v : s.hull->vertices) far = std::max(far, (T_shape * v - T_tcp.translation()).dot(z));
    } else if (s.type == CollisionShape::Type::kBox) {
      for (int k = 0; k < 8; ++k) {
        const Vec3 corner(((k & 1) ? 0.5 : -0.5) * s.size.x(), ((k & 2) ? 0.5 : -0.5) * s.size.y(), ((k & 4) ? 0.5 : -0.5) * s.size.z());
        far = std::max(far, (T_shape * corner - T_tcp.translation()).dot(z));
      }
    } else {
      const double extent = s.type == CollisionShape::Type::kSphere ? s.size.x() : s.size.x() + 0.5 * s.size.y();
      far = (T_shape.translation() - T_tcp.translation()).dot(z) + extent;
    }
    reach = std::max(reach, far);
  }
  return reach;
}

void RobotModel::linkPoses(const VecX& q, double finger_opening, std::vector<Pose>& out) const {
  thread_local std::vector<Pose> F;
  frames(q, F);
  out.resize(links_.size());
  for (size_t i = 0; i < links_.size(); ++i) {
    const LinkInfo& l = links_[i];
    const Mat3& R = F[l.frame].linear();
    Vec3 p = F[l.frame].translation() + R * l.T_frame_joint.translation();
    const Mat3 Rl = R * l.T_frame_joint.linear();
    if (!l.finger_axis.isZero()) p += Rl * (l.finger_axis * finger_opening);
    out[i].linear() = Rl;
    out[i].translation() = p;
    out[i].makeAffine();
  }
}

void RobotModel::jacobian(const VecX& q, Jacobian& J) const {
  thread_local std::vector<Pose> F;
  frames(q, F);
  const Vec3 p_tcp = (F[dof()] * T_last_tcp_).translation();
  J.resize(6, dof());
  for (int k = 0; k < dof(); ++k) {
    const Vec3 z = F[k + 1].linear() * axis_[k];
    const Vec3 p = F[k + 1].translation();
    J.block<3, 1>(0, k) = z.cross(p_tcp - p);
    J.block<3, 1>(3, k) = z;
  }
}

int RobotModel::linkIndex(const std::string& name) const {
  for (size_t i = 0; i < links_.size(); ++i)
    if (links_[i].name == name) return static_cast<int>(i);
  return -1;
}

}  // namespace mm
