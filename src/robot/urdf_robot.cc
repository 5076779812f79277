// A robot from a URDF: the arm is the chain of revolute joints from the base link to the flange
// link (fixed links on it, and fixed links hanging from its links, are merged into the link they
// hang from; whatever hangs below the flange — a hand the URDF may carry — is left out: the
// gripper is a part of its own, mounted there). What a URDF lacks comes from its companion YAML
// (<file>.yaml, optional): acceleration and jerk limits, home, which links form the arm, the flange
// mounting, the simulator's extras, the closed-form IK and the default gripper.
#include <console_bridge/console.h>
#include <tinyxml2.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <sstream>

#include "core/error.h"
#include "core/pose.h"
#include "robot/spec_reader.h"
#include "robot/urdf_parse.h"

namespace mm {
namespace {

// Collects urdfdom's console messages so a rejected URDF is reported with urdfdom's reason.
class CaptureHandler : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR) messages += (messages.empty() ? "" : "; ") + text;
  }
  std::string messages;
};

Pose toPose(const urdf::Pose& p) {
  double x, y, z, w;
  p.rotation.getQuaternion(x, y, z, w);
  return makePose(Vec3(p.position.x, p.position.y, p.position.z), Quat(w, x, y, z));
}

std::array<double, 3> arr(const Vec3& v) { return {v.x(), v.y(), v.z()}; }
Vec3 vec(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

// URDF's roll-pitch-yaw (fixed axes X, then Y, then Z): R = Rz(yaw) Ry(pitch) Rx(roll).
std::array<double, 3> rpyOf(const Mat3& R) {
  const double pitch = std::asin(-std::clamp(R(2, 0), -1.0, 1.0));
  return {std::atan2(R(2, 1), R(2, 2)), pitch, std::atan2(R(1, 0), R(0, 0))};
}

// Mass properties of a link in its frame: mass, com, inertia about com (3x3).
struct Inertia {
  double mass = 0;
  Vec3 com = Vec3::Zero();
  Mat3 I = Mat3::Zero();
};

// `b` seen from the frame where `T` places it, added to `a`.
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

}  // namespace

std::shared_ptr<urdf::ModelInterface> parseUrdfText(const std::string& text, const std::string& origin) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(text.c_str()) != tinyxml2::XML_SUCCESS)
    throw InputError(origin + ":" + std::to_string(doc.ErrorLineNum()),
                     std::string("malformed XML (expected a URDF robot description): ") + doc.ErrorStr());
  static std::mutex mutex;  // console_bridge's handler is global
  std::lock_guard<std::mutex> lock(mutex);
  CaptureHandler handler;
  console_bridge::useOutputHandler(&handler);
  auto model = urdf::parseURDF(text);
  console_bridge::restorePreviousOutputHandler();
  if (!model)
    throw InputError(origin, "not a valid URDF robot description: " +
                                 (handler.messages.empty() ? std::string("urdfdom rejected it") : handler.messages));
  return model;
}

RobotSpec loadUrdfRobotSpec(const std::string& urdf_path, const std::string& gripper_yaml) {
  namespace fs = std::filesystem;
  std::ifstream in(urdf_path);
  if (!in) throw InputError(urdf_path, "cannot open file (expected a URDF robot description)");
  std::stringstream text;
  text << in.rdbuf();
  const auto model = parseUrdfText(text.str(), urdf_path);

  // The companion YAML, when there is one.
  RobotSpec s;
  s.file = urdf_path;
  const std::string side = urdf_path + ".yaml";
  YAML::Node y = YAML::Node(YAML::NodeType::Map);
  if (fs::exists(side)) {
    s.sidecar = side;
    y = spec_io::loadYaml(side, "a URDF's companion YAML");
  }
  const spec_io::Reader r{side};
  for (auto it = y.begin(); it != y.end(); ++it) {
    static const std::vector<std::string> keys = {"name", "base_link", "flange_link", "flange_d", "hand_yaw", "acceleration", "jerk",
                                                  "home", "damping", "armature", "analytic_ik", "gripper", "package_path"};
    const std::string k = it->first.Scalar();
    if (std::find(keys.begin(), keys.end(), k) == keys.end())
      throw InputError(r.at(it->first), "unknown key '" + k + "' in a URDF's companion YAML");
  }
  auto number = [&](const char* key, double fallback) { return y[key] ? r.number(y, key) : fallback; };
  s.name = y["name"] ? r.text(y, "name") : model->getName();
  s.base_link = y["base_link"] ? r.text(y, "base_link") : model->getRoot()->name;
  const auto base = model->getLink(s.base_link);
  if (!base) throw InputError(y["base_link"] ? r.at(y["base_link"]) : urdf_path, "base link '" + s.base_link + "' is not in " + urdf_path);

  // The flange: named, or the end of the only chain of moving joints below the base.
  std::string flange_name;
  if (y["flange_link"]) {
    flange_name = r.text(y, "flange_link");
  } else {
    auto l = base;
    for (;;) {
      urdf::LinkConstSharedPtr next;
      int moving = 0;
      for (const auto& j : l->child_joints)
        if (j->type == urdf::Joint::REVOLUTE || j->type == urdf::Joint::CONTINUOUS) ++moving, next = model->getLink(j->child_link_name);
      if (moving == 0) break;
      if (moving > 1)
        throw InputError(urdf_path, "link '" + l->name + "' has several moving children: name the arm's last link as flange_link in " + side);
      l = next;
    }
    flange_name = l->name;
  }
  const auto flange = model->getLink(flange_name);
  if (!flange) throw InputError(y["flange_link"] ? r.at(y["flange_link"]) : urdf_path, "flange link '" + flange_name + "' is not in " + urdf_path);
  std::vector<urdf::JointConstSharedPtr> chain;
  for (auto l = flange; l->name != s.base_link; l = l->getParent()) {
    if (!l->parent_joint) throw InputError(urdf_path, "link '" + flange_name + "' is not below base link '" + s.base_link + "'");
    chain.push_back(l->parent_joint);
  }
  std::reverse(chain.begin(), chain.end());

  // Links below the flange belong to whatever the URDF mounts there: left out.
  std::function<bool(const urdf::LinkConstSharedPtr&)> belowFlange = [&](const urdf::LinkConstSharedPtr& l) {
    for (auto p = l->getParent(); p; p = p->getParent())
      if (p->name == flange_name) return true;
    return false;
  };
  // A moving link with everything fixed to it (not below the flange, not the next chain link).
  std::vector<std::string> chain_children;
  for (const auto& j : chain) chain_children.push_back(j->child_link_name);
  auto onChain = [&](const std::string& n) { return std::find(chain_children.begin(), chain_children.end(), n) != chain_children.end(); };
  const std::vector<std::string> package_path = [&] {
    std::vector<std::string> dirs;
    if (y["package_path"]) {
      if (!y["package_path"].IsSequence()) throw InputError(r.at(y["package_path"]), "'package_path' expects a list of folders");
      for (const auto& d : y["package_path"]) {
        const fs::path p = d.as<std::string>();
        dirs.push_back(p.is_absolute() ? p.string() : (fs::path(side).parent_path() / p).lexically_normal().string());
      }
    }
    if (const char* env = std::getenv("ROS_PACKAGE_PATH")) {
      std::stringstream ss(env);
      for (std::string d; std::getline(ss, d, ':');)
        if (!d.empty()) dirs.push_back(d);
    }
    return dirs;
  }();
  auto shapesOf = [&](const urdf::LinkConstSharedPtr& l, const Pose& T, LinkSpec& out, Inertia& inertia) {
    if (l->inertial) {
      Inertia b;
      b.mass = l->inertial->mass;
      b.com = toPose(l->inertial->origin).translation();
      const Mat3 R = toPose(l->inertial->origin).linear();
      Mat3 I;
      I << l->inertial->ixx, l->inertial->ixy, l->inertial->ixz, l->inertial->ixy, l->inertial->iyy, l->inertial->iyz,
          l->inertial->ixz, l->inertial->iyz, l->inertial->izz;
      b.I = R * I * R.transpose();
      addInertia(inertia, b, T);
    }
    for (const auto& c : l->collision_array) {
      if (!c || !c->geometry) continue;
      const Pose Tc = T * toPose(c->origin);
      ShapeSpec sh;
      switch (c->geometry->type) {
        case urdf::Geometry::SPHERE:
          sh.type = ShapeSpec::Type::kSphere;
          sh.pos = arr(Tc.translation());
          sh.radius = static_cast<const urdf::Sphere&>(*c->geometry).radius;
          break;
        case urdf::Geometry::CYLINDER: {
          const auto& cy = static_cast<const urdf::Cylinder&>(*c->geometry);
          sh.type = ShapeSpec::Type::kCylinder;
          const Vec3 half = Tc.linear().col(2) * (0.5 * cy.length);
          sh.from = arr(Tc.translation() - half);
          sh.to = arr(Tc.translation() + half);
          sh.radius = cy.radius;
          break;
        }
        case urdf::Geometry::BOX: {
          const auto& b = static_cast<const urdf::Box&>(*c->geometry);
          sh.type = ShapeSpec::Type::kBox;
          sh.pos = arr(Tc.translation());
          sh.half = {0.5 * b.dim.x, 0.5 * b.dim.y, 0.5 * b.dim.z};
          const Quat q(Tc.linear());
          sh.quat = {q.w(), q.x(), q.y(), q.z()};
          break;
        }
        case urdf::Geometry::MESH: {
          std::string f = static_cast<const urdf::Mesh&>(*c->geometry).filename;
          const std::string where = urdf_path + ": link '" + l->name + "'";
          if (f.rfind("package://", 0) == 0) {
            const std::string rel = f.substr(10);
            std::string found;
            for (const auto& d : package_path)
              if (fs::exists(fs::path(d) / rel)) {
                found = (fs::path(d) / rel).string();
                break;
              }
            if (found.empty())
              throw InputError(where, "cannot resolve '" + f + "' (looked in package_path of " + side + " and ROS_PACKAGE_PATH)");
            f = found;
          } else if (f.rfind("file://", 0) == 0) {
            f = f.substr(7);
          } else if (fs::path(f).is_relative()) {
            f = (fs::path(urdf_path).parent_path() / f).string();
          }
          std::string ext = fs::path(f).extension().string();
          for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
          if (ext == ".dae") throw InputError(where, "mesh '" + f + "' is COLLADA (.dae), which MuJoCo 2.2 cannot read (convert it to STL or OBJ)");
          if (!std::ifstream(f)) throw InputError(where, "cannot read mesh '" + f + "'");
          throw InputError(where, "mesh '" + f + "': mesh collision shapes are not supported yet (describe the link with primitives)");
        }
      }
      out.shapes.push_back(sh);
    }
  };
  std::function<void(const urdf::LinkConstSharedPtr&, const Pose&, LinkSpec&, Inertia&)> gather =
      [&](const urdf::LinkConstSharedPtr& l, const Pose& T, LinkSpec& out, Inertia& inertia) {
        shapesOf(l, T, out, inertia);
        if (l->name == flange_name) return;  // what hangs below the flange is the gripper's place
        for (const auto& j : l->child_joints) {
          if (onChain(j->child_link_name)) continue;
          if (j->type != urdf::Joint::FIXED)
            throw InputError(urdf_path, "joint '" + j->name + "' moves but is not on the arm's chain " + s.base_link + " -> " +
                                            flange_name + " (name the arm's links with base_link and flange_link in " + side + ")");
          gather(model->getLink(j->child_link_name), T * toPose(j->parent_to_joint_origin_transform), out, inertia);
        }
      };
  // A cylinder with spheres of its radius on both end points is a capsule (URDF has none; writers,
  // ours included, write a capsule so): one shape again, the same solid.
  auto mergeCapsules = [](std::vector<ShapeSpec>& shapes) {
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
  };
  auto finishLink = [&](LinkSpec& ls, const Inertia& in) {
    mergeCapsules(ls.shapes);
    if (in.mass <= 0) throw InputError(urdf_path, "link '" + ls.name + "' has no mass (expected an <inertial> on it or a link fixed to it)");
    ls.mass = in.mass;
    ls.has_inertia = true;
    ls.com = arr(in.com);
    ls.inertia = {in.I(0, 0), in.I(1, 1), in.I(2, 2), in.I(0, 1), in.I(0, 2), in.I(1, 2)};
    if (ls.shapes.empty())
      throw InputError(urdf_path, "link '" + ls.name + "' has no collision shape (expected a <collision> on it or a link fixed to it)");
    s.links.push_back(ls);
  };

  // Walk the chain: fixed joints fold into the next joint's origin (and their links into the moving
  // link before them).
  LinkSpec current{s.base_link};
  Inertia current_inertia;
  gather(base, Pose::Identity(), current, current_inertia);
  Pose T_acc = Pose::Identity();  // from the last moving link's frame
  for (const auto& j : chain) {
    const Pose T_origin = T_acc * toPose(j->parent_to_joint_origin_transform);
    const auto child = model->getLink(j->child_link_name);
    if (j->type == urdf::Joint::FIXED) {
      gather(child, T_origin, current, current_inertia);
      T_acc = T_origin;
      continue;
    }
    if (j->type != urdf::Joint::REVOLUTE && j->type != urdf::Joint::CONTINUOUS)
      throw InputError(urdf_path, "joint '" + j->name + "' on the arm's chain must be revolute, continuous or fixed");
    finishLink(current, current_inertia);
    JointSpec js;
    js.name = j->name;
    js.xyz = arr(T_origin.translation());
    js.rpy = rpyOf(T_origin.linear());
    js.axis = arr(Vec3(j->axis.x, j->axis.y, j->axis.z).normalized());
    const auto& lim = j->limits;
    if (j->type == urdf::Joint::CONTINUOUS) js.lower = -2 * M_PI, js.upper = 2 * M_PI;
    else if (lim) js.lower = lim->lower, js.upper = lim->upper;
    if (!(js.lower < js.upper)) throw InputError(urdf_path, "joint '" + j->name + "': expected <limit lower < upper>");
    if (!lim || !(lim->velocity > 0) || !(lim->effort > 0))
      throw InputError(urdf_path, "joint '" + j->name + "': expected <limit> with velocity > 0 and effort > 0");
    js.velocity = lim->velocity;
    js.effort = lim->effort;
    // Modified DH when the origin has that form: rpy (alpha, 0, 0), axis z, xyz (a, -sin(alpha) d, cos(alpha) d).
    const double al = js.rpy[0];
    const double d = -std::sin(al) * js.xyz[1] + std::cos(al) * js.xyz[2];
    js.dh = std::abs(js.rpy[1]) < 1e-9 && std::abs(js.rpy[2]) < 1e-9 && std::abs(js.axis[0]) < 1e-12 &&
            std::abs(js.axis[1]) < 1e-12 && js.axis[2] > 0 && std::abs(std::cos(al) * js.xyz[1] + std::sin(al) * js.xyz[2]) < 1e-9;
    if (js.dh) js.a = js.xyz[0], js.d = d, js.alpha = al;
    s.joints.push_back(js);
    current = LinkSpec{child->name};
    current_inertia = Inertia{};
    T_acc = Pose::Identity();
    gather(child, Pose::Identity(), current, current_inertia);
  }
  finishLink(current, current_inertia);
  if (s.joints.empty()) throw InputError(urdf_path, "no moving joint between " + s.base_link + " and " + flange_name);

  // The flange: the last joint's frame, the fixed transform to the flange link, then the mounting.
  const Pose T_flange = T_acc * makePose(Vec3(0, 0, number("flange_d", 0.0)), Eigen::AngleAxisd(number("hand_yaw", 0.0), Vec3::UnitZ()).toRotationMatrix());
  s.flange_xyz = arr(T_flange.translation());
  s.flange_rpy = rpyOf(T_flange.linear());
  s.flange_d = number("flange_d", 0.0);
  s.hand_yaw = number("hand_yaw", 0.0);

  // Per-joint figures a URDF does not carry: one value for all joints, or a list.
  const size_t n = s.joints.size();
  auto perJoint = [&](const char* key, double fallback, bool positive) {
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
        if (!std::isfinite(v[i]) || (positive && v[i] <= 0)) throw InputError(r.at(node[i]), std::string("'") + key + "' values must be finite and > 0");
      }
    } else {
      throw InputError(r.at(node), std::string("'") + key + "' expects a number or " + std::to_string(n) + " numbers");
    }
    return v;
  };
  // Defaults when unsaid: of the Panda's order (the URDF format has no acceleration or jerk limits).
  const auto acc = perJoint("acceleration", 10.0, true), jerk = perJoint("jerk", 5000.0, true);
  std::vector<double> home(n);
  for (size_t i = 0; i < n; ++i) home[i] = std::clamp(0.0, s.joints[i].lower, s.joints[i].upper);
  if (y["home"]) home = perJoint("home", 0.0, false);
  for (size_t i = 0; i < n; ++i) {
    s.joints[i].acceleration = acc[i];
    s.joints[i].jerk = jerk[i];
    if (!(home[i] >= s.joints[i].lower && home[i] <= s.joints[i].upper))
      throw InputError(r.at(y["home"]), "'home' value " + std::to_string(home[i]) + " is outside the limits of " + s.joints[i].name);
  }
  s.home = home;
  s.damping = number("damping", 0.5);
  s.armature = number("armature", 0.1);
  if (y["analytic_ik"]) {
    s.analytic_ik = r.text(y, "analytic_ik");
    if (s.analytic_ik != "panda" && s.analytic_ik != "ur")
      throw InputError(r.at(y["analytic_ik"]), "'analytic_ik' expects panda or ur, got '" + s.analytic_ik + "'");
  }
  std::string gpath = gripper_yaml;
  if (gpath.empty()) {
    if (!y["gripper"])
      throw InputError(urdf_path, "no gripper: name one in " + side + " (gripper: path) or with the experiment's gripper key");
    const std::string rel = r.text(y, "gripper");
    gpath = fs::path(rel).is_absolute() ? rel : (fs::path(side).parent_path() / rel).lexically_normal().string();
  }
  spec_io::mountGripper(s, gpath);
  return s;
}

}  // namespace mm
