#include "robot/robot_spec.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "robot/spec_reader.h"

namespace mm {
namespace spec_io {
namespace {

ShapeSpec readShape(const Reader& r, const YAML::Node& n) {
  ShapeSpec s;
  const std::string type = r.text(n, "type");
  if (type == "capsule" || type == "cylinder") {
    s.type = type == "capsule" ? ShapeSpec::Type::kCapsule : ShapeSpec::Type::kCylinder;
    s.from = r.vec3(n, "from");
    s.to = r.vec3(n, "to");
    s.radius = r.positive(n, "radius");
    const double len = std::hypot(s.to[0] - s.from[0], s.to[1] - s.from[1], s.to[2] - s.from[2]);
    if (len < 1e-6) throw InputError(r.at(n), type + " needs distinct 'from' and 'to'");
  } else if (type == "box") {
    s.type = ShapeSpec::Type::kBox;
    s.pos = r.vec3(n, "pos");
    s.half = r.vec3(n, "half");
    for (double h : s.half)
      if (h <= 0) throw InputError(r.at(n["half"]), "box 'half' sizes must be > 0");
  } else if (type == "sphere") {
    s.type = ShapeSpec::Type::kSphere;
    s.pos = r.vec3(n, "pos");
    s.radius = r.positive(n, "radius");
  } else {
    throw InputError(r.at(n["type"]), "'type' expects capsule, cylinder, box or sphere, got '" + type + "'");
  }
  return s;
}

}  // namespace

LinkSpec readLink(const Reader& r, const YAML::Node& l) {
  LinkSpec ls;
  ls.name = r.text(l, "name");
  ls.mass = r.positive(l, "mass");
  const YAML::Node shapes = r.require(l, "shapes", l);
  if (!shapes.IsSequence() || shapes.size() == 0)
    throw InputError(r.at(shapes), "'shapes' expects a list of collision primitives");
  for (const auto& sh : shapes) ls.shapes.push_back(readShape(r, sh));
  return ls;
}

YAML::Node loadYaml(const std::string& path, const char* what) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw InputError(path, std::string("cannot open file (expected ") + what + ")");
  } catch (const YAML::Exception& e) {
    throw InputError(path + ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1),
                     "malformed YAML: " + e.msg);
  }
  if (!root.IsMap()) throw InputError(path, std::string("expected a YAML map: ") + what);
  return root;
}

void mountGripper(RobotSpec& s, const std::string& gpath) {
  s.gripper = loadGripperSpec(gpath);
  s.tip_link = s.gripper.tcp;
  s.tcp_offset = s.gripper.tcp_offset;
  s.links.push_back(s.gripper.hand);
  s.links.push_back(s.gripper.fingers[0]);
  s.links.push_back(s.gripper.fingers[1]);
  // Every name once: the descriptions and the simulator find bodies and joints by name.
  std::vector<std::string> seen;
  for (const auto& l : s.links) seen.push_back(l.name);
  for (const auto& j : s.joints) seen.push_back(j.name);
  seen.push_back(s.tip_link);
  seen.push_back(s.gripper.finger_joints[0]);
  seen.push_back(s.gripper.finger_joints[1]);
  std::sort(seen.begin(), seen.end());
  for (size_t i = 1; i < seen.size(); ++i)
    if (seen[i] == seen[i - 1])
      throw InputError(s.file, "the name '" + seen[i] + "' is used twice by the arm and its gripper (" + gpath + ")");
}

std::string gripperPath(const std::string& chosen, const Reader& r, const YAML::Node& map, const std::string& file) {
  if (!chosen.empty()) return chosen;
  const std::filesystem::path rel = r.text(map, "gripper");
  return rel.is_absolute() ? rel.string() : (std::filesystem::path(file).parent_path() / rel).lexically_normal().string();
}

std::string readAnalyticIk(const Reader& r, const YAML::Node& map) {
  if (!map["analytic_ik"]) return "";
  const std::string form = r.text(map, "analytic_ik");
  if (form != "panda" && form != "ur")
    throw InputError(r.at(map["analytic_ik"]), "'analytic_ik' expects panda or ur, got '" + form + "'");
  return form;
}

}  // namespace spec_io

using spec_io::Reader;
using spec_io::loadYaml;
using spec_io::readLink;

std::vector<std::string> RobotSpec::names() const {
  std::vector<std::string> out{name, base_link, tip_link, gripper.name, gripper.finger_joints[0], gripper.finger_joints[1]};
  for (const auto& j : joints) out.push_back(j.name);
  for (const auto& l : links) out.push_back(l.name);
  return out;
}

GripperSpec loadGripperSpec(const std::string& path) {
  Reader r{path};
  const YAML::Node root = loadYaml(path, "a gripper YAML");
  GripperSpec g;
  g.file = path;
  g.name = r.text(root, "name");
  g.travel = r.positive(root, "travel");
  g.max_force = r.positive(root, "max_force");
  g.velocity = r.positive(root, "velocity");
  g.finger_z = r.number(root, "finger_z");
  g.pad_friction = r.positive(root, "pad_friction");
  const YAML::Node tcp = r.require(root, "tcp", root);
  g.tcp = r.text(tcp, "name");
  g.tcp_offset = r.positive(tcp, "offset");
  g.hand = readLink(r, r.require(root, "hand", root));
  const YAML::Node fingers = r.require(root, "fingers", root);
  if (!fingers.IsSequence() || fingers.size() != 2)
    throw InputError(r.at(fingers), "'fingers' expects two fingers: the one opening along +y, then the one along -y");
  for (size_t k = 0; k < 2; ++k) {
    g.fingers[k] = readLink(r, fingers[k]);
    g.finger_joints[k] = r.text(fingers[k], "joint");
  }
  if (g.finger_joints[0] == g.finger_joints[1]) throw InputError(r.at(fingers), "the fingers' joints need distinct names");
  return g;
}

std::string RobotSpec::directory() const { return std::filesystem::path(file).parent_path().string(); }
std::string RobotSpec::mjcfPath() const { return (std::filesystem::path(directory()) / (name + ".xml")).string(); }
std::string RobotSpec::urdfPath() const { return (std::filesystem::path(directory()) / (name + ".urdf")).string(); }

RobotSpec loadRobotSpec(const std::string& path, const std::string& gripper_yaml) {
  if (std::filesystem::path(path).extension() == ".xacro")
    throw InputError(path, "a .xacro file is a template of a URDF: run xacro first (\"xacro " +
                               std::filesystem::path(path).filename().string() +
                               " > robot.urdf\") and name the .urdf. xacro is not in Debian 12: it comes with ROS "
                               "(ros-<distro>-xacro) or from PyPI (pip install xacro)");
  if (std::filesystem::path(path).extension() == ".urdf") return loadUrdfRobotSpec(path, gripper_yaml);
  if (std::filesystem::path(path).extension() == ".xml")
    throw InputError(path, "an MJCF robot is read through the simulator (sim/mjcf_robot.h: loadAnyRobot)");
  Reader r{path};
  const YAML::Node root = loadYaml(path, "a robot YAML describing an arm");
  RobotSpec s;
  s.file = path;
  s.name = r.text(root, "name");
  s.base_link = r.text(root, "base_link");
  s.analytic_ik = spec_io::readAnalyticIk(r, root);
  const YAML::Node joints = r.require(root, "joints", root);
  if (!joints.IsSequence() || joints.size() < 1)
    throw InputError(r.at(joints), "'joints' expects a list of joints");
  for (const auto& j : joints) {
    JointSpec js;
    js.name = r.text(j, "name");
    js.a = r.number(j, "a");
    js.d = r.number(j, "d");
    js.alpha = r.number(j, "alpha");
    js.lower = r.number(j, "lower");
    js.upper = r.number(j, "upper");
    if (!(js.lower < js.upper)) throw InputError(r.at(j), "joint '" + js.name + "': 'lower' must be < 'upper'");
    js.velocity = r.positive(j, "velocity");
    js.acceleration = r.positive(j, "acceleration");
    js.jerk = r.positive(j, "jerk");
    js.effort = r.positive(j, "effort");
    js.xyz = {js.a, -std::sin(js.alpha) * js.d, std::cos(js.alpha) * js.d};
    js.rpy = {js.alpha, 0, 0};
    s.joints.push_back(js);
  }
  s.flange_d = r.number(root, "flange_d");
  s.hand_yaw = r.number(root, "hand_yaw");
  s.flange_xyz = {0, 0, s.flange_d};
  s.flange_rpy = {0, 0, s.hand_yaw};
  const YAML::Node home = r.require(root, "home", root);
  if (!home.IsSequence() || home.size() != s.joints.size())
    throw InputError(r.at(home), "'home' expects " + std::to_string(s.joints.size()) + " joint values");
  for (size_t i = 0; i < home.size(); ++i) {
    double v;
    try {
      v = home[i].as<double>();
    } catch (const YAML::Exception&) {
      throw InputError(r.at(home[i]), "'home' expects numbers");
    }
    if (!(v >= s.joints[i].lower && v <= s.joints[i].upper))
      throw InputError(r.at(home[i]), "'home' value " + std::to_string(v) + " is outside the limits of " + s.joints[i].name);
    s.home.push_back(v);
  }
  s.home_source = "yaml";
  s.damping = r.number(root, "damping");
  s.armature = r.number(root, "armature");
  const YAML::Node links = r.require(root, "links", root);
  if (!links.IsSequence() || links.size() != s.joints.size() + 1)
    throw InputError(r.at(links), "'links' expects " + std::to_string(s.joints.size() + 1) +
                                      " links: the base, then one per joint");
  for (const auto& l : links) s.links.push_back(readLink(r, l));
  if (s.links.front().name != s.base_link)
    throw InputError(r.at(links), "the first link must be the base link '" + s.base_link + "'");

  // The gripper: the experiment's choice, else the robot's default (relative to the robot file).
  spec_io::mountGripper(s, spec_io::gripperPath(gripper_yaml, r, root, path));
  return s;
}

}  // namespace mm
