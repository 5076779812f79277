#include "robot/arm_builder.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "core/error.h"

namespace mm::arm_builder {

std::vector<double> Companion::perJoint(const char* key, size_t n, double fallback, bool positive) const {
  std::vector<double> v(n, fallback);
  if (!y[key]) return v;
  const YAML::Node node = y[key];
  if (node.IsScalar()) {
    std::fill(v.begin(), v.end(), positive ? r.positive(y, key) : r.number(y, key));
  } else if (node.IsSequence() && node.size() == n) {
    for (size_t i = 0; i < n; ++i) {
      try {
        v[i] = node[i].as<double>();
      } catch (const YAML::Exception&) {
        throw InputError(r.at(node[i]), std::string("'") + key + "' expects numbers");
      }
      if (!std::isfinite(v[i]) || (positive && v[i] <= 0))
        throw InputError(r.at(node[i]), std::string("'") + key + "' values must be finite" + (positive ? " and > 0" : ""));
    }
  } else {
    throw InputError(r.at(node), std::string("'") + key + "' expects a number or " + std::to_string(n) + " numbers");
  }
  return v;
}

Companion loadCompanion(const std::string& description, const char* format, const std::vector<std::string>& extra_keys) {
  Companion c{description + ".yaml", YAML::Node(YAML::NodeType::Map), spec_io::Reader{description + ".yaml"}};
  if (std::filesystem::exists(c.path)) c.y = spec_io::loadYaml(c.path, (std::string("a ") + format + "'s companion YAML").c_str());
  std::vector<std::string> keys = {"name", "base_link", "flange_link", "flange_d", "hand_yaw", "acceleration", "jerk",
                                   "home", "damping", "armature", "analytic_ik", "gripper", "default_link_mass"};
  keys.insert(keys.end(), extra_keys.begin(), extra_keys.end());
  for (auto it = c.y.begin(); it != c.y.end(); ++it) {
    const std::string k = it->first.Scalar();
    if (std::find(keys.begin(), keys.end(), k) == keys.end())
      throw InputError(c.r.at(it->first), "unknown key '" + k + "' in " + (std::string("a ") + format + "'s companion YAML"));
  }
  return c;
}

void addInertia(Inertia& a, const Inertia& b, const Pose& T) {
  if (b.mass <= 0) return;
  const Vec3 cb = T * b.com;
  const Mat3 Ib = T.linear() * b.I * T.linear().transpose();
  const double m = a.mass + b.mass;
  const Vec3 c = (a.mass * a.com + b.mass * cb) / m;
  auto shift = [](double mass, const Vec3& d) { return mass * (d.squaredNorm() * Mat3::Identity() - d * d.transpose()); };
  a.I = a.I + shift(a.mass, a.com - c) + Ib + shift(b.mass, cb - c);
  a.com = c;
  a.mass = m;
}

std::array<double, 3> arr(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

std::array<double, 3> rpyOf(const Mat3& R) {
  const double pitch = std::asin(-std::clamp(R(2, 0), -1.0, 1.0));
  // At pitch +-pi/2 roll and yaw turn about one axis: roll 0, all of it in yaw.
  if (std::abs(R(2, 0)) > 1 - 1e-12) return {0.0, pitch, std::atan2(-R(0, 1), R(1, 1))};
  return {std::atan2(R(2, 1), R(2, 2)), pitch, std::atan2(R(1, 0), R(0, 0))};
}

void recognizeDh(JointSpec& js) {
  // Modified DH: rpy (alpha, 0, 0), axis z, xyz (a, -sin(alpha) d, cos(alpha) d).
  const double al = js.rpy[0];
  const double d = -std::sin(al) * js.xyz[1] + std::cos(al) * js.xyz[2];
  js.dh = std::abs(js.rpy[1]) < 1e-9 && std::abs(js.rpy[2]) < 1e-9 && std::abs(js.axis[0]) < 1e-12 &&
          std::abs(js.axis[1]) < 1e-12 && js.axis[2] > 0 && std::abs(std::cos(al) * js.xyz[1] + std::sin(al) * js.xyz[2]) < 1e-9;
  if (js.dh) js.a = js.xyz[0], js.d = d, js.alpha = al;
}

namespace {

std::string fmt(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", v);
  return b;
}

// A cylinder with spheres of its radius on both end points is a capsule (URDF has none; writers,
// ours included, write a capsule so): one shape again, the same solid.
void mergeCapsules(std::vector<ShapeSpec>& shapes) {
  auto same = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return std::abs(a[0] - b[0]) < 1e-9 && std::abs(a[1] - b[1]) < 1e-9 && std::abs(a[2] - b[2]) < 1e-9;
  };
  for (size_t c = 0; c < shapes.size(); ++c) {
    if (shapes[c].type != ShapeSpec::Type::kCylinder) continue;
    int ends[2] = {-1, -1};
    for (size_t k = 0; k < shapes.size(); ++k) {
      const ShapeSpec& sp = shapes[k];
      if (sp.type != ShapeSpec::Type::kSphere || std::abs(sp.radius - shapes[c].radius) > 1e-9) continue;
      if (ends[0] < 0 && same(sp.pos, shapes[c].from)) ends[0] = static_cast<int>(k);
      else if (ends[1] < 0 && same(sp.pos, shapes[c].to)) ends[1] = static_cast<int>(k);
    }
    if (ends[0] < 0 || ends[1] < 0) continue;
    shapes[c].type = ShapeSpec::Type::kCapsule;
    const int hi = std::max(ends[0], ends[1]), lo = std::min(ends[0], ends[1]);
    shapes.erase(shapes.begin() + hi);
    shapes.erase(shapes.begin() + lo);
    c = static_cast<size_t>(-1);  // indices moved: look again from the start
  }
}

}  // namespace

void addLink(RobotSpec& s, LinkSpec ls, const Inertia& in, const std::string& description, const Companion& c) {
  mergeCapsules(ls.shapes);
  const bool base = s.links.empty();  // welded to the world: its mass and shapes may be absent
  if (ls.shapes.empty() && !base)
    throw InputError(description, "link '" + ls.name + "' has no collision shape (expected one on it or on a link fixed to it)");
  if (in.mass <= 0) {
    if (base) {
      ls.mass = 0;  // static: the simulator needs no mass for it
      ls.has_inertia = false;
    } else if (c.y["default_link_mass"]) {
      ls.mass = c.r.positive(c.y, "default_link_mass");  // spread over its collision shapes by volume
      ls.has_inertia = false;
      s.notes.push_back("link '" + ls.name + "' has no inertial: default_link_mass " + fmt(ls.mass) +
                        " kg, its inertia from its collision shapes");
    } else {
      throw InputError(description, "link '" + ls.name + "' has no mass (expected an inertia on it or on a link fixed to it, or "
                                    "default_link_mass: <kg> in " + c.path + " to give such links a mass, their inertia from "
                                    "their collision shapes)");
    }
    s.links.push_back(ls);
    return;
  }
  ls.mass = in.mass;
  ls.has_inertia = true;
  ls.com = arr(in.com);
  Mat3 I = in.I;
  // Principal moments A <= B <= C must satisfy A + B >= C (a rigid body's); published files
  // sometimes do not. As MuJoCo's balanceinertia: all three become their mean.
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(0.5 * (I + I.transpose()));
  const Vec3 m = eig.eigenvalues();  // ascending
  if (m(0) + m(1) < m(2)) {
    const double mean = m.sum() / 3;
    I = mean * Mat3::Identity();
    if (m(2) - m(0) - m(1) > 1e-6 * m(2))
      s.notes.push_back("link '" + ls.name + "': its principal moments of inertia (" + fmt(m(0)) + ", " + fmt(m(1)) + ", " + fmt(m(2)) +
                        " kg m^2) violate A + B >= C: balanced to " + fmt(mean) + " each (MuJoCo's balanceinertia)");
  }
  ls.inertia = {I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2)};
  s.links.push_back(ls);
}

int toolFrameRank(const std::string& name) {
  std::string n = name;
  for (char& ch : n) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  if (n == "tool0" || (n.size() > 6 && n.compare(n.size() - 6, 6, "_tool0") == 0)) return 0;
  if (n == "flange" || (n.size() > 7 && n.compare(n.size() - 7, 7, "_flange") == 0)) return 1;
  if (n.find("_ee") != std::string::npos || n.rfind("ee_", 0) == 0) return 2;
  if (n.rfind("end_effector", 0) == 0) return 3;
  return -1;
}

void finishArm(RobotSpec& s, const Companion& c, const Pose& T_last_flange, const std::string& gripper_yaml,
               const std::string& description, const std::vector<double>& file_home) {
  const YAML::Node& y = c.y;
  const auto& r = c.r;
  if (s.joints.empty()) throw InputError(description, "no moving joint on the arm's chain");
  // The flange: the last joint's frame, the fixed transform to the flange link, then the mounting.
  s.flange_d = c.number("flange_d", 0.0);
  s.hand_yaw = c.number("hand_yaw", 0.0);
  const Pose T_flange = T_last_flange * makePose(Vec3(0, 0, s.flange_d), Eigen::AngleAxisd(s.hand_yaw, Vec3::UnitZ()).toRotationMatrix());
  s.flange_xyz = arr(T_flange.translation());
  s.flange_rpy = rpyOf(T_flange.linear());
  // Defaults when unsaid: of the Panda's order (URDF and MJCF carry no acceleration or jerk limits).
  const size_t n = s.joints.size();
  const auto acc = c.perJoint("acceleration", n, 10.0, true), jerk = c.perJoint("jerk", n, 5000.0, true);
  std::vector<double> home(n);
  for (size_t i = 0; i < n; ++i) home[i] = std::clamp(0.0, s.joints[i].lower, s.joints[i].upper);
  s.home_source = "";
  if (y["home"]) {
    home = c.perJoint("home", n, 0.0, false);
    s.home_source = "yaml";
  } else if (file_home.size() == n) {
    home = file_home;
    s.home_source = "keyframe";
  }
  for (size_t i = 0; i < n; ++i) {
    s.joints[i].acceleration = acc[i];
    s.joints[i].jerk = jerk[i];
    if (!(home[i] >= s.joints[i].lower && home[i] <= s.joints[i].upper))
      throw InputError(y["home"] ? r.at(y["home"]) : description, std::string(y["home"] ? "'home'" : "the keyframe 'home'") + " value " +
                                                                       std::to_string(home[i]) + " is outside the limits of " + s.joints[i].name);
  }
  s.home = home;
  s.damping = c.number("damping", 0.5);
  s.armature = c.number("armature", 0.1);
  s.analytic_ik = spec_io::readAnalyticIk(r, y);
  if (gripper_yaml.empty() && !y["gripper"])
    throw InputError(description, "no gripper: name one in " + c.path + " (gripper: path) or with the experiment's gripper key");
  spec_io::mountGripper(s, spec_io::gripperPath(gripper_yaml, r, y, c.path));
}

}  // namespace mm::arm_builder
