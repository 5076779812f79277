#include "robot/description_writer.h"

#include <Eigen/Dense>
#include <cmath>
#include <algorithm>
#include <cstdio>
#include <sstream>

#include "robot/mesh.h"

namespace mm {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

std::string num(double v) {
  if (std::abs(v) < 1e-15) v = 0.0;
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.12g", v);
  return buf;
}
std::string vec(const Vector3d& v) { return num(v.x()) + " " + num(v.y()) + " " + num(v.z()); }
Vector3d toV(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

// Mass properties of one link: mass spread over its shapes in proportion to volume, each shape a
// uniform solid (a capsule as a cylinder of its length plus 4/3 r, a fair approximation).
struct MassProps {
  Vector3d com = Vector3d::Zero();
  Matrix3d inertia = Matrix3d::Zero();  // about com, link axes
};

MassProps massProps(const LinkSpec& link) {
  if (link.has_inertia) {  // the description's own
    MassProps mp;
    mp.com = toV(link.com);
    const auto& I = link.inertia;
    mp.inertia << I[0], I[3], I[4], I[3], I[1], I[5], I[4], I[5], I[2];
    return mp;
  }
  struct Part { double vol; Vector3d c; Matrix3d I_unit; };  // I per unit mass, about c
  std::vector<Part> parts;
  for (const auto& s : link.shapes) {
    Part p;
    if (s.type == ShapeSpec::Type::kBox) {
      const Vector3d h = toV(s.half);
      p.vol = 8 * h.prod();
      p.c = toV(s.pos);
      p.I_unit = Matrix3d::Zero();
      p.I_unit.diagonal() << (h.y() * h.y() + h.z() * h.z()) / 3, (h.x() * h.x() + h.z() * h.z()) / 3,
          (h.x() * h.x() + h.y() * h.y()) / 3;
      const Matrix3d R = Eigen::Quaterniond(s.quat[0], s.quat[1], s.quat[2], s.quat[3]).normalized().toRotationMatrix();
      p.I_unit = R * p.I_unit * R.transpose();
    } else if (s.type == ShapeSpec::Type::kMesh) {  // as its hull's bounding box in the mesh's frame
      const auto hull = meshHull(s.mesh, toV(s.scale));
      const Vector3d h = 0.5 * (hull->upper - hull->lower);
      const Matrix3d R = Eigen::Quaterniond(s.quat[0], s.quat[1], s.quat[2], s.quat[3]).normalized().toRotationMatrix();
      p.vol = 8 * h.prod();
      p.c = toV(s.pos) + R * (0.5 * (hull->upper + hull->lower));
      p.I_unit = Matrix3d::Zero();
      p.I_unit.diagonal() << (h.y() * h.y() + h.z() * h.z()) / 3, (h.x() * h.x() + h.z() * h.z()) / 3,
          (h.x() * h.x() + h.y() * h.y()) / 3;
      p.I_unit = R * p.I_unit * R.transpose();
    } else if (s.type == ShapeSpec::Type::kSphere) {
      p.vol = 4.0 / 3.0 * M_PI * std::pow(s.radius, 3);
      p.c = toV(s.pos);
      p.I_unit = Matrix3d::Identity() * 0.4 * s.radius * s.radius;
    } else {
      const Vector3d a = toV(s.from), b = toV(s.to);
      const double r = s.radius;
      double L = (b - a).norm();
      p.vol = M_PI * r * r * L;
      if (s.type == ShapeSpec::Type::kCapsule) {
        p.vol += 4.0 / 3.0 * M_PI * r * r * r;
        L += 4.0 / 3.0 * r;
      }
      p.c = 0.5 * (a + b);
      const Vector3d axis = (b - a).normalized();
      const double Iax = 0.5 * r * r, Iperp = (3 * r * r + L * L) / 12.0;
      p.I_unit = Iperp * Matrix3d::Identity() + (Iax - Iperp) * axis * axis.transpose();
    }
    parts.push_back(p);
  }
  double vol = 0;
  for (const auto& p : parts) vol += p.vol;
  MassProps mp;
  for (const auto& p : parts) mp.com += p.vol / vol * p.c;
  for (const auto& p : parts) {
    const double m = link.mass * p.vol / vol;
    const Vector3d d = p.c - mp.com;
    mp.inertia += m * p.I_unit + m * (d.squaredNorm() * Matrix3d::Identity() - d * d.transpose());
  }
  return mp;
}

// Pose of joint i's frame in the previous frame (modified DH): translation and rotation Rx(alpha).
Vector3d dhPos(const JointSpec& j) { return {j.a, -std::sin(j.alpha) * j.d, std::cos(j.alpha) * j.d}; }

bool identityQuat(const std::array<double, 4>& q) { return q[0] == 1 && q[1] == 0 && q[2] == 0 && q[3] == 0; }

// URDF roll-pitch-yaw as a quaternion "w x y z" (R = Rz(yaw) Ry(pitch) Rx(roll)).
std::string quatRpy(const std::array<double, 3>& rpy) {
  const Eigen::Quaterniond q = Eigen::AngleAxisd(rpy[2], Vector3d::UnitZ()) * Eigen::AngleAxisd(rpy[1], Vector3d::UnitY()) *
                               Eigen::AngleAxisd(rpy[0], Vector3d::UnitX());
  return num(q.w()) + " " + num(q.x()) + " " + num(q.y()) + " " + num(q.z());
}

std::string mjcfGeoms(const LinkSpec& link, const std::string& indent, const std::string& cls) {
  std::ostringstream o;
  int k = 0;
  for (const auto& s : link.shapes) {
    o << indent << "<geom name=\"" << link.name << "_c" << k++ << "\" class=\"" << cls << "\" ";
    switch (s.type) {
      case ShapeSpec::Type::kCapsule:
      case ShapeSpec::Type::kCylinder:
        o << "type=\"" << (s.type == ShapeSpec::Type::kCapsule ? "capsule" : "cylinder") << "\" fromto=\""
          << vec(toV(s.from)) << " " << vec(toV(s.to)) << "\" size=\"" << num(s.radius) << "\"";
        break;
      case ShapeSpec::Type::kBox:
        o << "type=\"box\" pos=\"" << vec(toV(s.pos)) << "\" size=\"" << vec(toV(s.half)) << "\"";
        if (!identityQuat(s.quat))
          o << " quat=\"" << num(s.quat[0]) << " " << num(s.quat[1]) << " " << num(s.quat[2]) << " " << num(s.quat[3]) << "\"";
        break;
      case ShapeSpec::Type::kSphere:
        o << "type=\"sphere\" pos=\"" << vec(toV(s.pos)) << "\" size=\"" << num(s.radius) << "\"";
        break;
      case ShapeSpec::Type::kMesh:
        o << "type=\"mesh\" mesh=\"" << link.name << "_c" << (k - 1) << "_hull\" pos=\"" << vec(toV(s.pos)) << "\"";
        if (!identityQuat(s.quat))
          o << " quat=\"" << num(s.quat[0]) << " " << num(s.quat[1]) << " " << num(s.quat[2]) << " " << num(s.quat[3]) << "\"";
        break;
    }
    o << "/>\n";
  }
  return o.str();
}

// A mesh shape's convex hull as an inline mesh asset (its vertices; MuJoCo takes their hull), named
// after the geom that uses it: MuJoCo collides the hull we computed, not its own reading of the file.
std::string mjcfMeshAssets(const std::vector<const LinkSpec*>& links) {
  std::ostringstream o;
  for (const LinkSpec* link : links) {
    int k = 0;
    for (const auto& s : link->shapes) {
      ++k;
      if (s.type != ShapeSpec::Type::kMesh) continue;
      const auto hull = meshHull(s.mesh, toV(s.scale));
      o << "    <mesh name=\"" << link->name << "_c" << (k - 1) << "_hull\" vertex=\"";
      for (size_t i = 0; i < hull->vertices.size(); ++i) o << (i ? " " : "") << vec(hull->vertices[i]);
      o << "\"/>  <!-- the convex hull of " << s.mesh << " -->\n";
    }
  }
  return o.str();
}

std::string mjcfInertial(const LinkSpec& link, const std::string& indent) {
  if (link.mass <= 0) return "";  // a massless base, welded to the world
  const MassProps mp = massProps(link);
  const Matrix3d& I = mp.inertia;
  return indent + "<inertial pos=\"" + vec(mp.com) + "\" mass=\"" + num(link.mass) + "\" fullinertia=\"" +
         num(I(0, 0)) + " " + num(I(1, 1)) + " " + num(I(2, 2)) + " " + num(I(0, 1)) + " " + num(I(0, 2)) +
         " " + num(I(1, 2)) + "\"/>\n";
}

std::string quatX(double a) { return num(std::cos(a / 2)) + " " + num(std::sin(a / 2)) + " 0 0"; }
std::string quatZ(double a) { return num(std::cos(a / 2)) + " 0 0 " + num(std::sin(a / 2)); }
std::string rpyText(const std::array<double, 3>& rpy) { return num(rpy[0]) + " " + num(rpy[1]) + " " + num(rpy[2]); }

}  // namespace

std::string writeMjcf(const RobotSpec& spec) {
  std::ostringstream o;
  const size_t n = spec.joints.size();
  const auto& g = spec.gripper;
  o << "<!-- " << spec.name << " with " << g.name << ": generated from their YAML files by gen_robot. Do not edit;"
    << " edit the YAML and regenerate. -->\n";
  o << "<mujoco model=\"" << spec.name << "\">\n";
  // Angles (joint ranges) are in radians; a scene mounting this robot declares its own compiler
  // (sim/scene_compose.cc converts the ranges when that scene works in degrees).
  o << "  <compiler angle=\"radian\"/>\n\n";
  {
    std::vector<const LinkSpec*> all;
    for (const auto& l : spec.links) all.push_back(&l);  // the arm's, then the hand and its fingers
    const std::string assets = mjcfMeshAssets(all);
    if (!assets.empty()) o << "  <asset>\n" << assets << "  </asset>\n\n";
  }
  o << "  <default>\n    <default class=\"" << spec.name << "\">\n";
  o << "      <joint damping=\"" << num(spec.damping) << "\" armature=\"" << num(spec.armature) << "\"/>\n";
  o << "      <default class=\"" << spec.name << "_col\">\n";
  o << "        <geom rgba=\"0.92 0.92 0.95 1\" friction=\"0.6 0.005 0.0001\"/>\n      </default>\n";
  // The pads' solref and solimp govern their contacts (solmix: MuJoCo otherwise averages them with
  // the other geom's, a scene object's default 0.02 s). MuJoCo's friction holds by damping the
  // sliding velocity alone, at b = 2 / (dmax timeconst), and its constraints leave out the
  // velocity-product acceleration (J'qdot) of a hand swung on the arm: a held object creeps along
  // the pads at about J'qdot / b. 0.004 s (2 timesteps, the stiffest MuJoCo allows) and dmax 0.99
  // creep a fifth of the averaged 0.012 s.
  o << "      <default class=\"" << spec.name << "_pad\">\n";
  o << "        <geom rgba=\"0.2 0.2 0.2 1\" condim=\"4\" friction=\"" << num(g.pad_friction)
    << " 0.02 0.0001\" solref=\"0.004 1\" solimp=\"0.95 0.99 0.001\" solmix=\"1000\"/>\n      </default>\n";
  o << "    </default>\n  </default>\n\n  <worldbody>\n";
  std::string ind = "    ";
  o << ind << "<body name=\"" << spec.links[0].name << "\" childclass=\"" << spec.name << "\">\n";
  o << mjcfInertial(spec.links[0], ind + "  ") << mjcfGeoms(spec.links[0], ind + "  ", spec.name + "_col");
  for (size_t i = 0; i < n; ++i) {
    const auto& j = spec.joints[i];
    const auto& link = spec.links[i + 1];
    ind += "  ";
    o << ind << "<body name=\"" << link.name << "\" pos=\"" << (j.dh ? vec(dhPos(j)) : vec(toV(j.xyz))) << "\" quat=\""
      << (j.dh ? quatX(j.alpha) : quatRpy(j.rpy)) << "\">\n";
    o << mjcfInertial(link, ind + "  ");
    o << ind << "  <joint name=\"" << j.name << "\" axis=\"" << (j.dh ? std::string("0 0 1") : vec(toV(j.axis))) << "\" range=\"" << num(j.lower) << " "
      << num(j.upper) << "\" limited=\"true\"/>\n";
    o << mjcfGeoms(link, ind + "  ", spec.name + "_col");
  }
  const auto& hand = spec.links[n + 1];
  const auto& lf = spec.links[n + 2];
  const auto& rf = spec.links[n + 3];
  ind += "  ";
  const bool yaw_only = spec.flange_rpy[0] == 0 && spec.flange_rpy[1] == 0;
  o << ind << "<body name=\"" << hand.name << "\" pos=\"" << vec(toV(spec.flange_xyz)) << "\" quat=\""
    << (yaw_only ? quatZ(spec.flange_rpy[2]) : quatRpy(spec.flange_rpy)) << "\">\n";
  o << mjcfInertial(hand, ind + "  ") << mjcfGeoms(hand, ind + "  ", spec.name + "_col");
  o << ind << "  <site name=\"" << spec.tip_link << "\" pos=\"0 0 " << num(spec.tcp_offset)
    << "\" size=\"0.005\" rgba=\"1 0 0 1\"/>\n";
  o << ind << "  <camera name=\"wrist_camera\" pos=\"0.05 0 0.04\" xyaxes=\"0 1 0 1 0 0\" fovy=\"60\"/>\n";
  const std::pair<const LinkSpec*, int> fingers[] = {{&lf, 1}, {&rf, -1}};
  int fi = 0;
  for (const auto& [f, sign] : fingers) {
    o << ind << "  <body name=\"" << f->name << "\" pos=\"0 0 " << num(g.finger_z) << "\">\n";
    o << mjcfInertial(*f, ind + "    ");
    o << ind << "    <joint name=\"" << g.finger_joints[fi++] << "\" type=\"slide\" axis=\"0 "
      << sign << " 0\" range=\"0 " << num(g.travel) << "\" limited=\"true\" damping=\"2\" armature=\"0.01\"/>\n";
    o << mjcfGeoms(*f, ind + "    ", spec.name + "_pad");
    o << ind << "  </body>\n";
  }
  o << ind << "</body>\n";
  for (size_t i = n + 1; i-- > 0;) {
    o << std::string(4 + 2 * i, ' ') << "</body>\n";
  }
  o << "  </worldbody>\n\n  <contact>\n";
  // MuJoCo's parent filter skips bodies welded to the world, so the base-link1 pair is explicit.
  o << "    <exclude body1=\"" << spec.links[0].name << "\" body2=\"" << spec.links[1].name << "\"/>\n";
  // The hand and the last links are rigidly close; their pairs are excluded as MoveIt's ACM does.
  o << "    <exclude body1=\"" << spec.links[n].name << "\" body2=\"" << lf.name << "\"/>\n";
  o << "    <exclude body1=\"" << spec.links[n].name << "\" body2=\"" << rf.name << "\"/>\n";
  o << "    <exclude body1=\"" << lf.name << "\" body2=\"" << rf.name << "\"/>\n";
  o << "  </contact>\n\n  <equality>\n";
  // The fingers are coupled, as the hand's mechanism (and the URDF's mimic joint) couples them.
  o << "    <joint name=\"" << g.name << "_finger_coupling\" joint1=\"" << g.finger_joints[0] << "\" joint2=\""
    << g.finger_joints[1] << "\" solref=\"0.005 1\"/>\n";
  o << "  </equality>\n\n  <actuator>\n";
  for (const auto& j : spec.joints)
    o << "    <motor name=\"" << j.name << "\" joint=\"" << j.name << "\" ctrllimited=\"true\" ctrlrange=\""
      << num(-j.effort) << " " << num(j.effort) << "\"/>\n";
  for (int k = 0; k < 2; ++k)
    o << "    <motor name=\"" << g.finger_joints[k] << "\" joint=\"" << g.finger_joints[k] << "\" ctrllimited=\"true\" ctrlrange=\"" << num(-g.max_force) << " "
      << num(g.max_force) << "\"/>\n";
  o << "  </actuator>\n</mujoco>\n";
  return o.str();
}

namespace {

std::string urdfInertial(const LinkSpec& link) {
  if (link.mass <= 0) return "";  // a massless base, welded to the world
  const MassProps mp = massProps(link);
  const Matrix3d& I = mp.inertia;
  return "    <inertial>\n      <origin xyz=\"" + vec(mp.com) + "\" rpy=\"0 0 0\"/>\n      <mass value=\"" +
         num(link.mass) + "\"/>\n      <inertia ixx=\"" + num(I(0, 0)) + "\" ixy=\"" + num(I(0, 1)) + "\" ixz=\"" +
         num(I(0, 2)) + "\" iyy=\"" + num(I(1, 1)) + "\" iyz=\"" + num(I(1, 2)) + "\" izz=\"" + num(I(2, 2)) +
         "\"/>\n    </inertial>\n";
}

// Roll-pitch-yaw (URDF's fixed-axis XYZ) that rotates z onto `axis`.
std::string rpyForZ(const Vector3d& axis) {
  const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(Vector3d::UnitZ(), axis);
  const Matrix3d R = q.toRotationMatrix();
  const double pitch = std::asin(-std::clamp(R(2, 0), -1.0, 1.0));
  const bool lock = std::abs(R(2, 0)) > 1 - 1e-12;  // roll and yaw about one axis: all in yaw
  const double roll = lock ? 0.0 : std::atan2(R(2, 1), R(2, 2));
  const double yaw = lock ? std::atan2(-R(0, 1), R(1, 1)) : std::atan2(R(1, 0), R(0, 0));
  return num(roll) + " " + num(pitch) + " " + num(yaw);
}

std::string rpyOfQuat(const std::array<double, 4>& q) {
  const Matrix3d R = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  const double pitch = std::asin(-std::clamp(R(2, 0), -1.0, 1.0));
  if (std::abs(R(2, 0)) > 1 - 1e-12) return "0 " + num(pitch) + " " + num(std::atan2(-R(0, 1), R(1, 1)));  // gimbal lock
  return num(std::atan2(R(2, 1), R(2, 2))) + " " + num(pitch) + " " + num(std::atan2(R(1, 0), R(0, 0)));
}

std::string urdfCollision(const LinkSpec& link) {
  std::ostringstream o;
  auto sphere = [&](const Vector3d& c, double r) {
    o << "    <collision>\n      <origin xyz=\"" << vec(c) << "\" rpy=\"0 0 0\"/>\n      <geometry><sphere radius=\""
      << num(r) << "\"/></geometry>\n    </collision>\n";
  };
  for (const auto& s : link.shapes) {
    switch (s.type) {
      case ShapeSpec::Type::kBox:
        o << "    <collision>\n      <origin xyz=\"" << vec(toV(s.pos)) << "\" rpy=\""
          << (identityQuat(s.quat) ? std::string("0 0 0") : rpyOfQuat(s.quat)) << "\"/>\n"
          << "      <geometry><box size=\"" << vec(2 * toV(s.half)) << "\"/></geometry>\n    </collision>\n";
        break;
      case ShapeSpec::Type::kSphere: sphere(toV(s.pos), s.radius); break;
      case ShapeSpec::Type::kMesh:
        o << "    <collision>\n      <origin xyz=\"" << vec(toV(s.pos)) << "\" rpy=\""
          << (identityQuat(s.quat) ? std::string("0 0 0") : rpyOfQuat(s.quat)) << "\"/>\n"
          << "      <geometry><mesh filename=\"" << s.mesh << "\" scale=\"" << vec(toV(s.scale)) << "\"/></geometry>\n    </collision>\n";
        break;
      case ShapeSpec::Type::kCapsule:
      case ShapeSpec::Type::kCylinder: {
        const Vector3d a = toV(s.from), b = toV(s.to);
        o << "    <collision>\n      <origin xyz=\"" << vec(0.5 * (a + b)) << "\" rpy=\"" << rpyForZ((b - a).normalized())
          << "\"/>\n      <geometry><cylinder radius=\"" << num(s.radius) << "\" length=\"" << num((b - a).norm())
          << "\"/></geometry>\n    </collision>\n";
        if (s.type == ShapeSpec::Type::kCapsule) {
          sphere(a, s.radius);
          sphere(b, s.radius);
        }
      }
    }
  }
  return o.str();
}

}  // namespace

std::string writeUrdf(const RobotSpec& spec) {
  std::ostringstream o;
  const size_t n = spec.joints.size();
  const auto& g = spec.gripper;
  o << "<?xml version=\"1.0\"?>\n<!-- " << spec.name << " with " << g.name
    << ": generated from their YAML files by gen_robot. Do not edit; edit the YAML and regenerate. -->\n";
  o << "<robot name=\"" << spec.name << "\">\n";
  for (size_t i = 0; i < spec.links.size(); ++i) {
    const auto& l = spec.links[i];
    o << "  <link name=\"" << l.name << "\">\n" << urdfInertial(l) << urdfCollision(l) << "  </link>\n";
  }
  o << "  <link name=\"" << spec.tip_link << "\"/>\n";
  for (size_t i = 0; i < n; ++i) {
    const auto& j = spec.joints[i];
    o << "  <joint name=\"" << j.name << "\" type=\"revolute\">\n    <parent link=\"" << spec.links[i].name
      << "\"/>\n    <child link=\"" << spec.links[i + 1].name << "\"/>\n    <origin xyz=\""
      << (j.dh ? vec(dhPos(j)) : vec(toV(j.xyz))) << "\" rpy=\"" << (j.dh ? num(j.alpha) + " 0 0" : rpyText(j.rpy))
      << "\"/>\n    <axis xyz=\"" << (j.dh ? std::string("0 0 1") : vec(toV(j.axis))) << "\"/>\n    <limit lower=\"" << num(j.lower)
      << "\" upper=\"" << num(j.upper) << "\" effort=\"" << num(j.effort) << "\" velocity=\"" << num(j.velocity)
      << "\"/>\n    <dynamics damping=\"" << num(spec.damping) << "\"/>\n  </joint>\n";
  }
  const auto& hand = spec.links[n + 1];
  o << "  <joint name=\"" << hand.name << "_joint\" type=\"fixed\">\n    <parent link=\"" << spec.links[n].name
    << "\"/>\n    <child link=\"" << hand.name << "\"/>\n    <origin xyz=\"" << vec(toV(spec.flange_xyz))
    << "\" rpy=\"" << rpyText(spec.flange_rpy) << "\"/>\n  </joint>\n";
  o << "  <joint name=\"" << spec.tip_link << "_joint\" type=\"fixed\">\n    <parent link=\"" << hand.name
    << "\"/>\n    <child link=\"" << spec.tip_link << "\"/>\n    <origin xyz=\"0 0 " << num(spec.tcp_offset)
    << "\" rpy=\"0 0 0\"/>\n  </joint>\n";
  for (int k = 1; k <= 2; ++k) {
    o << "  <joint name=\"" << g.finger_joints[k - 1] << "\" type=\"prismatic\">\n    <parent link=\""
      << hand.name << "\"/>\n    <child link=\"" << spec.links[n + 1 + k].name << "\"/>\n    <origin xyz=\"0 0 "
      << num(g.finger_z) << "\" rpy=\"0 0 0\"/>\n    <axis xyz=\"0 " << (k == 1 ? 1 : -1)
      << " 0\"/>\n    <limit lower=\"0\" upper=\"" << num(g.travel) << "\" effort=\"" << num(g.max_force)
      << "\" velocity=\"" << num(g.velocity) << "\"/>\n";
    if (k == 2) o << "    <mimic joint=\"" << g.finger_joints[0] << "\"/>\n";
    o << "  </joint>\n";
  }
  o << "</robot>\n";
  return o.str();
}

}  // namespace mm
