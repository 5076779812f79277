#include "robot/arm_builder.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
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
                                   "home", "damping", "armature", "analytic_ik", "gripper"};
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

void addLink(RobotSpec& s, LinkSpec ls, const Inertia& in, const std::string& description) {
  mergeCapsules(ls.shapes);
  if (in.mass <= 0)
    throw InputError(description, "link '" + ls.name + "' has no mass (expected an inertia on it or on a link fixed to it)");
  ls.mass = in.mass;
  ls.has_inertia = true;
  ls.com = arr(in.com);
  ls.inertia = {in.I(0, 0), in.I(1, 1), in.I(2, 2), in.I(0, 1), in.I(0, 2), in.I(1, 2)};
  if (ls.shapes.empty())
    throw InputError(description, "link '" + ls.name + "' has no collision shape (expected one on it or on a link fixed to it)");
  s.links.push_back(ls);
}

void finishArm(RobotSpec& s, const Companion& c, const Pose& T_last_flange, const std::string& gripper_yaml,
               const std::string& description) {
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
  if (y["home"]) home = c.perJoint("home", n, 0.0, false);
  for (size_t i = 0; i < n; ++i) {
    s.joints[i].acceleration = acc[i];
    s.joints[i].jerk = jerk[i];
    if (!(home[i] >= s.joints[i].lower && home[i] <= s.joints[i].upper))
      throw InputError(r.at(y["home"]), "'home' value " + std::to_string(home[i]) + " is outside the limits of " + s.joints[i].name);
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
