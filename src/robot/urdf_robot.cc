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
#include <map>
#include <mutex>
#include <sstream>

#include "core/error.h"
#include "core/pose.h"
#include "robot/arm_builder.h"
#include "robot/mesh.h"
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

}  // namespace

std::shared_ptr<urdf::ModelInterface> parseUrdfText(const std::string& text, const std::string& origin) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(text.c_str()) != tinyxml2::XML_SUCCESS)
    throw InputError(origin + ":" + std::to_string(doc.ErrorLineNum()),
                     std::string("malformed XML (expected a URDF robot description): ") + doc.ErrorStr());
  // A link with two parents (a cycle, or a graph that is not a tree) is refused here: urdfdom
  // reports it too, but leaks the half-built model's shared_ptr cycle.
  if (const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot")) {
    std::map<std::string, std::string> parent_joint;
    for (const tinyxml2::XMLElement* j = robot->FirstChildElement("joint"); j; j = j->NextSiblingElement("joint")) {
      const tinyxml2::XMLElement* child = j->FirstChildElement("child");
      const char* link = child ? child->Attribute("link") : nullptr;
      const char* name = j->Attribute("name");
      if (!link || !name) continue;  // urdfdom says what is missing
      const auto [it, fresh] = parent_joint.emplace(link, name);
      if (!fresh)
        throw InputError(origin + ":" + std::to_string(j->GetLineNum()), "not a valid URDF robot description: link '" +
                                                                             std::string(link) + "' is the child of two joints, '" +
                                                                             it->second + "' and '" + name + "' (not a tree)");
    }
    // Every link one parent at most, yet a loop apart from the root: walking up never ends.
    std::map<std::string, std::string> parent_link;
    for (const tinyxml2::XMLElement* j = robot->FirstChildElement("joint"); j; j = j->NextSiblingElement("joint")) {
      const tinyxml2::XMLElement *c = j->FirstChildElement("child"), *p = j->FirstChildElement("parent");
      if (c && p && c->Attribute("link") && p->Attribute("link")) parent_link[c->Attribute("link")] = p->Attribute("link");
    }
    for (const auto& [start, unused] : parent_link) {
      std::string l = start;
      for (size_t steps = 0; parent_link.count(l); ++steps) {
        l = parent_link.at(l);
        if (steps > parent_link.size())
          throw InputError(origin, "not a valid URDF robot description: the joints form a cycle through link '" + start + "'");
      }
    }
  }
  static std::mutex mutex;  // console_bridge's handler is global
  std::lock_guard<std::mutex> lock(mutex);
  CaptureHandler handler;
  struct Restore {  // even if urdfdom throws
    ~Restore() { console_bridge::restorePreviousOutputHandler(); }
  };
  console_bridge::useOutputHandler(&handler);
  std::shared_ptr<urdf::ModelInterface> model;
  {
    Restore restore;
    model = urdf::parseURDF(text);
  }
  if (!model)
    throw InputError(origin, "not a valid URDF robot description: " +
                                 (handler.messages.empty() ? std::string("urdfdom rejected it") : handler.messages));
  return model;
}

std::vector<std::string> urdfSearchDirs(const std::string& urdf_path, std::vector<std::string> first) {
  if (const char* env = std::getenv("ROS_PACKAGE_PATH")) {
    std::stringstream ss(env);
    for (std::string d; std::getline(ss, d, ':');)
      if (!d.empty()) first.push_back(d);
  }
  // Then the URDF's folder and its ancestors: a package as published keeps its urdf/ and meshes/
  // side by side, so package://<pkg>/meshes/... is found above the URDF, in the package's parent.
  for (std::filesystem::path d = std::filesystem::absolute(urdf_path).lexically_normal().parent_path();; d = d.parent_path()) {
    first.push_back(d.string());
    if (d == d.parent_path()) break;
  }
  return first;
}

std::string resolveUrdfMesh(const std::string& filename, const std::string& urdf_path, const std::vector<std::string>& dirs,
                            const std::string& where, const std::string& searched) {
  if (filename.rfind("package://", 0) == 0) {
    const std::string rel = filename.substr(10);
    for (const auto& d : dirs)
      if (std::filesystem::exists(std::filesystem::path(d) / rel)) return (std::filesystem::path(d) / rel).string();
    throw InputError(where, "cannot resolve '" + filename + "' (looked in " + searched + ")");
  }
  if (filename.rfind("file://", 0) == 0) return filename.substr(7);
  if (std::filesystem::path(filename).is_relative()) return (std::filesystem::path(urdf_path).parent_path() / filename).string();
  return filename;
}

RobotSpec loadUrdfRobotSpec(const std::string& urdf_path, const std::string& gripper_yaml) {
  namespace fs = std::filesystem;
  std::ifstream in(urdf_path);
  if (!in) throw InputError(urdf_path, "cannot open file (expected a URDF robot description)");
  std::stringstream text;
  text << in.rdbuf();
  if (text.str().find("<xacro:") != std::string::npos)
    throw InputError(urdf_path, "this URDF still holds xacro macros (<xacro:...>): run xacro on it first and name its "
                                "output. xacro is not in Debian 12: it comes with ROS (ros-<distro>-xacro) or from "
                                "PyPI (pip install xacro)");
  const auto model = parseUrdfText(text.str(), urdf_path);

  // The companion YAML, when there is one.
  RobotSpec s;
  s.file = urdf_path;
  const arm_builder::Companion comp = arm_builder::loadCompanion(urdf_path, "URDF", {"package_path"});
  if (fs::exists(comp.path)) s.sidecar = comp.path;
  const YAML::Node& y = comp.y;
  const spec_io::Reader& r = comp.r;
  const std::string& side = comp.path;
  s.name = y["name"] ? r.text(y, "name") : model->getName();
  // The base: named, or the root link — unless the root is 'world' with one fixed child, the
  // convention of files meant to be welded somewhere: then the world is ours, the child the base.
  s.base_link = model->getRoot()->name;
  if (y["base_link"]) {
    s.base_link = r.text(y, "base_link");
  } else if (s.base_link == "world" && model->getRoot()->child_joints.size() == 1 &&
             model->getRoot()->child_joints[0]->type == urdf::Joint::FIXED) {
    s.base_link = model->getRoot()->child_joints[0]->child_link_name;
    s.notes.push_back("root link 'world' is the world: the arm's base is '" + s.base_link + "'");
  }
  const auto base = model->getLink(s.base_link);
  if (!base) throw InputError(y["base_link"] ? r.at(y["base_link"]) : urdf_path, "base link '" + s.base_link + "' is not in " + urdf_path);

  // The arm's joints turn (revolute or continuous); what slides below them (a hand's fingers) is
  // a hand the URDF carries.
  auto turns = [](const urdf::JointConstSharedPtr& j) {
    return j->type == urdf::Joint::REVOLUTE || j->type == urdf::Joint::CONTINUOUS;
  };
  std::function<bool(const urdf::LinkConstSharedPtr&)> turnsBelow = [&](const urdf::LinkConstSharedPtr& l) {
    for (const auto& j : l->child_joints)
      if (turns(j) || turnsBelow(model->getLink(j->child_link_name))) return true;
    return false;
  };
  // A hand's root: a link with a moving child joint that is not one of the arm's.
  auto holdsHand = [&](const urdf::LinkConstSharedPtr& l) {
    for (const auto& j : l->child_joints)
      if (j->type != urdf::Joint::FIXED && !turns(j)) return true;
    return false;
  };

  // The flange: named; else, below the chain's last turning link, a frame fixed to it named like
  // a tool frame (tool0, flange, *_ee*, end_effector*); else the link a shipped hand hangs from;
  // else the last turning link.
  std::string flange_name;
  if (y["flange_link"]) {
    flange_name = r.text(y, "flange_link");
    s.flange_choice = "flange_link in " + side;
  } else {
    auto l = base;
    for (;;) {
      urdf::LinkConstSharedPtr next;
      int moving = 0;
      for (const auto& j : l->child_joints) {
        const auto child = model->getLink(j->child_link_name);
        if (turns(j) || turnsBelow(child)) ++moving, next = child;
      }
      if (moving == 0) break;
      if (moving > 1)
        throw InputError(urdf_path, "link '" + l->name + "' has several turning children: name the arm's last link as flange_link in " + side);
      l = next;
    }
    flange_name = l->name;
    s.flange_choice = "the last link the arm's joints turn";
    // Frames fixed below it, breadth first, not into a shipped hand.
    int best = 99;
    std::string hand_root;
    std::vector<urdf::LinkConstSharedPtr> level = {l};
    while (!level.empty()) {
      std::vector<urdf::LinkConstSharedPtr> next_level;
      for (const auto& k : level) {
        if (holdsHand(k)) {
          if (hand_root.empty()) hand_root = k->name;
          continue;
        }
        for (const auto& j : k->child_joints) {
          if (j->type != urdf::Joint::FIXED) continue;
          const auto c = model->getLink(j->child_link_name);
          const int rank = arm_builder::toolFrameRank(c->name);
          if (rank >= 0 && rank < best) best = rank, flange_name = c->name;
          next_level.push_back(c);
        }
      }
      level = next_level;
    }
    if (best < 99) s.flange_choice = "a frame fixed after the last joint, named like a tool frame";
    else if (!hand_root.empty()) flange_name = hand_root, s.flange_choice = "the link the robot file's own hand hangs from";
  }
  s.flange_link = flange_name;
  const auto flange = model->getLink(flange_name);
  if (!flange) throw InputError(y["flange_link"] ? r.at(y["flange_link"]) : urdf_path, "flange link '" + flange_name + "' is not in " + urdf_path);
  std::vector<urdf::JointConstSharedPtr> chain;
  for (auto l = flange; l->name != s.base_link; l = l->getParent()) {
    if (!l->parent_joint) throw InputError(urdf_path, "link '" + flange_name + "' is not below base link '" + s.base_link + "'");
    chain.push_back(l->parent_joint);
  }
  std::reverse(chain.begin(), chain.end());
  {  // What hangs below the flange is the place of our gripper: said when there is something.
    std::vector<std::string> below;
    std::function<void(const urdf::LinkConstSharedPtr&)> collect = [&](const urdf::LinkConstSharedPtr& l) {
      for (const auto& j : l->child_joints) {
        const auto c = model->getLink(j->child_link_name);
        if (!c->collision_array.empty() || j->type != urdf::Joint::FIXED) below.push_back(c->name);
        collect(c);
      }
    };
    collect(flange);
    if (!below.empty()) {
      std::string list;
      for (const auto& b : below) list += (list.empty() ? "" : ", ") + b;
      s.notes.push_back("the links below the flange '" + flange_name + "' (" + list + ") are left out: the gripper is a part of its own");
    }
  }

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
    return urdfSearchDirs(urdf_path, dirs);
  }();
  auto shapesOf = [&](const urdf::LinkConstSharedPtr& l, const Pose& T, LinkSpec& out, arm_builder::Inertia& inertia) {
    if (l->inertial) {
      arm_builder::Inertia b;
      b.mass = l->inertial->mass;
      b.com = toPose(l->inertial->origin).translation();
      const Mat3 R = toPose(l->inertial->origin).linear();
      Mat3 I;
      I << l->inertial->ixx, l->inertial->ixy, l->inertial->ixz, l->inertial->ixy, l->inertial->iyy, l->inertial->iyz,
          l->inertial->ixz, l->inertial->iyz, l->inertial->izz;
      b.I = R * I * R.transpose();
      arm_builder::addInertia(inertia, b, T);
    }
    for (const auto& c : l->collision_array) {
      if (!c || !c->geometry) continue;
      const Pose Tc = T * toPose(c->origin);
      ShapeSpec sh;
      switch (c->geometry->type) {
        case urdf::Geometry::SPHERE:
          sh.type = ShapeSpec::Type::kSphere;
          sh.pos = arm_builder::arr(Tc.translation());
          sh.radius = static_cast<const urdf::Sphere&>(*c->geometry).radius;
          break;
        case urdf::Geometry::CYLINDER: {
          const auto& cy = static_cast<const urdf::Cylinder&>(*c->geometry);
          sh.type = ShapeSpec::Type::kCylinder;
          const Vec3 half = Tc.linear().col(2) * (0.5 * cy.length);
          sh.from = arm_builder::arr(Tc.translation() - half);
          sh.to = arm_builder::arr(Tc.translation() + half);
          sh.radius = cy.radius;
          break;
        }
        case urdf::Geometry::BOX: {
          const auto& b = static_cast<const urdf::Box&>(*c->geometry);
          sh.type = ShapeSpec::Type::kBox;
          sh.pos = arm_builder::arr(Tc.translation());
          sh.half = {0.5 * b.dim.x, 0.5 * b.dim.y, 0.5 * b.dim.z};
          const Quat q(Tc.linear());
          sh.quat = {q.w(), q.x(), q.y(), q.z()};
          break;
        }
        case urdf::Geometry::MESH: {
          const std::string where = urdf_path + ": link '" + l->name + "'";
          const std::string f = resolveUrdfMesh(static_cast<const urdf::Mesh&>(*c->geometry).filename, urdf_path, package_path, where,
                                                "package_path of " + side + ", ROS_PACKAGE_PATH and the folders above the URDF");
          std::string ext = fs::path(f).extension().string();
          for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
          if (ext == ".dae") throw InputError(where, "mesh '" + f + "' is COLLADA (.dae), which MuJoCo 2.2 cannot read (convert it to STL or OBJ)");
          if (!std::ifstream(f)) throw InputError(where, "cannot read mesh '" + f + "'");
          const auto& me = static_cast<const urdf::Mesh&>(*c->geometry);
          sh.type = ShapeSpec::Type::kMesh;
          sh.mesh = fs::absolute(f).lexically_normal().string();
          sh.scale = {me.scale.x, me.scale.y, me.scale.z};
          try {
            meshHull(sh.mesh, Vec3(me.scale.x, me.scale.y, me.scale.z));  // read now: a bad mesh is an input error at load
          } catch (const InputError& e) {
            throw InputError(where, e.what());
          }
          sh.pos = arm_builder::arr(Tc.translation());
          const Quat q(Tc.linear());
          sh.quat = {q.w(), q.x(), q.y(), q.z()};
          break;
        }
      }
      out.shapes.push_back(sh);
    }
  };
  std::function<void(const urdf::LinkConstSharedPtr&, const Pose&, LinkSpec&, arm_builder::Inertia&)> gather =
      [&](const urdf::LinkConstSharedPtr& l, const Pose& T, LinkSpec& out, arm_builder::Inertia& inertia) {
        shapesOf(l, T, out, inertia);
        if (l->name == flange_name) return;  // what hangs below the flange is the gripper's place
        for (const auto& j : l->child_joints) {
          if (onChain(j->child_link_name)) continue;
          if (j->type != urdf::Joint::FIXED && !turns(j) && !turnsBelow(model->getLink(j->child_link_name))) {
            s.notes.push_back("link '" + j->child_link_name + "' slides off the arm's chain (a hand's part): left out");
            continue;
          }
          if (j->type != urdf::Joint::FIXED)
            throw InputError(urdf_path, "joint '" + j->name + "' moves but is not on the arm's chain " + s.base_link + " -> " +
                                            flange_name + " (name the arm's links with base_link and flange_link in " + side + ")");
          gather(model->getLink(j->child_link_name), T * toPose(j->parent_to_joint_origin_transform), out, inertia);
        }
      };
  // Walk the chain: fixed joints fold into the next joint's origin (and their links into the moving
  // link before them).
  LinkSpec current;
  current.name = s.base_link;
  arm_builder::Inertia current_inertia;
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
    arm_builder::addLink(s, current, current_inertia, urdf_path, comp);
    JointSpec js;
    js.name = j->name;
    js.xyz = arm_builder::arr(T_origin.translation());
    js.rpy = arm_builder::rpyOf(T_origin.linear());
    const Vec3 axis(j->axis.x, j->axis.y, j->axis.z);
    if (!(axis.norm() > 1e-9)) throw InputError(urdf_path, "joint '" + j->name + "': <axis xyz> is zero (expected a direction)");
    js.axis = arm_builder::arr(axis.normalized());
    const auto& lim = j->limits;
    if (j->type == urdf::Joint::CONTINUOUS) js.lower = -2 * M_PI, js.upper = 2 * M_PI;
    else if (lim) js.lower = lim->lower, js.upper = lim->upper;
    if (!(js.lower < js.upper)) throw InputError(urdf_path, "joint '" + j->name + "': expected <limit lower < upper>");
    if (!lim || !(lim->velocity > 0) || !(lim->effort > 0))
      throw InputError(urdf_path, "joint '" + j->name + "': expected <limit> with velocity > 0 and effort > 0");
    js.velocity = lim->velocity;
    js.effort = lim->effort;
    arm_builder::recognizeDh(js);
    s.joints.push_back(js);
    current = LinkSpec{};
    current.name = child->name;
    current_inertia = arm_builder::Inertia{};
    T_acc = Pose::Identity();
    gather(child, Pose::Identity(), current, current_inertia);
  }
  arm_builder::addLink(s, current, current_inertia, urdf_path, comp);
  arm_builder::finishArm(s, comp, T_acc, gripper_yaml, urdf_path);
  return s;
}

}  // namespace mm
