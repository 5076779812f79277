#include "sim/mjcf_robot.h"

#include <mujoco/mujoco.h>
#include <tinyxml2.h>

#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <regex>
#include <set>

#include "core/error.h"
#include "robot/arm_builder.h"
#include "robot/mesh.h"
#include "sim/mjcf_check.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

Pose bodyPose(const mjModel* m, int b) {
  const mjtNum* p = m->body_pos + 3 * b;
  const mjtNum* q = m->body_quat + 4 * b;
  return makePose(Vec3(p[0], p[1], p[2]), Quat(q[0], q[1], q[2], q[3]).normalized());
}

std::string bodyName(const mjModel* m, int b) {
  const char* n = mj_id2name(m, mjOBJ_BODY, b);
  return n ? n : "body " + std::to_string(b);
}

RobotSpec readMjcfArm(const std::string& path, const mjModel* m, const std::string& gripper_yaml) {
  const arm_builder::Companion comp = arm_builder::loadCompanion(path, "MJCF", {"velocity", "effort"});
  const YAML::Node& y = comp.y;
  RobotSpec s;
  s.file = path;
  if (std::filesystem::exists(comp.path)) s.sidecar = comp.path;
  s.name = y["name"] ? comp.r.text(y, "name") : std::filesystem::path(path).stem().string();
  auto bodyId = [&](const char* key, int fallback) {
    if (!y[key]) return fallback;
    const std::string n = comp.r.text(y, key);
    const int b = mj_name2id(m, mjOBJ_BODY, n.c_str());
    if (b < 0) throw InputError(comp.r.at(y[key]), "body '" + n + "' is not in " + path);
    return b;
  };
  auto children = [&](int b) {
    std::vector<int> c;
    for (int k = 1; k < m->nbody; ++k)
      if (k != b && m->body_parentid[k] == b) c.push_back(k);
    return c;
  };
  auto hasHinge = [&](int b) { return m->body_jntnum[b] > 0; };
  // The base: named, or the world's first child body.
  const int base = bodyId("base_link", m->nbody > 1 ? 1 : -1);
  if (base < 1) throw InputError(path, "expected a body under <worldbody>");
  s.base_link = bodyName(m, base);
  // The flange: named, or the end of the only chain of bodies with a joint below the base.
  std::function<bool(int)> slidesAny;  // set below
  std::function<bool(int)> movesBelow = [&](int b) {  // a hinge of the arm below b
    for (int c : children(b))
      if ((hasHinge(c) && !slidesAny(c)) || movesBelow(c)) return true;
    return false;
  };
  // The arm's joints are hinges; a body that slides (a hand's finger) is a hand the file carries.
  auto slides = [&](int b) {
    for (int j = m->body_jntadr[b]; j >= 0 && j < m->body_jntadr[b] + m->body_jntnum[b]; ++j)
      if (m->jnt_type[j] != mjJNT_HINGE) return true;
    return false;
  };
  slidesAny = slides;
  auto holdsHand = [&](int b) {
    for (int c : children(b))
      if (slides(c)) return true;
    return false;
  };
  // The flange: named; else, below the chain's last hinged body, a body fixed to it named like a
  // tool frame (tool0, flange, *_ee*, end_effector*); else the body a shipped hand hangs from; else
  // the last hinged body.
  int flange = base;
  if (y["flange_link"]) {
    flange = bodyId("flange_link", base);
    s.flange_choice = "flange_link in " + comp.path;
  } else {
    for (;;) {
      int next = -1, moving = 0;
      for (int c : children(flange))
        if ((hasHinge(c) && !slides(c)) || movesBelow(c)) ++moving, next = c;
      if (moving == 0) break;
      if (moving > 1)
        throw InputError(path, "body '" + bodyName(m, flange) + "' has several moving children: name the arm's last body as flange_link in " + comp.path);
      flange = next;
    }
    s.flange_choice = "the last body the arm's joints turn";
    int best = 99, hand_root = -1;
    std::vector<int> level = {flange};
    const int last = flange;
    while (!level.empty()) {
      std::vector<int> next_level;
      for (int k : level) {
        if (holdsHand(k)) {
          if (hand_root < 0) hand_root = k;
          continue;
        }
        for (int c : children(k)) {
          if (hasHinge(c)) continue;
          const int rank = arm_builder::toolFrameRank(bodyName(m, c));
          if (rank >= 0 && rank < best) best = rank, flange = c;
          next_level.push_back(c);
        }
      }
      level = next_level;
    }
    if (best < 99) s.flange_choice = "a body fixed after the last joint, named like a tool frame";
    else if (hand_root >= 0 && hand_root != last) flange = hand_root, s.flange_choice = "the body the robot file's own hand hangs from";
  }
  s.flange_link = bodyName(m, flange);
  {  // What hangs below the flange is the place of our gripper: said when there is something.
    std::string list;
    std::function<void(int)> collect = [&](int b) {
      for (int c : children(b)) {
        list += (list.empty() ? "" : ", ") + bodyName(m, c);
        collect(c);
      }
    };
    collect(flange);
    if (!list.empty()) s.notes.push_back("the bodies below the flange '" + s.flange_link + "' (" + list + ") are left out: the gripper is a part of its own");
  }
  std::vector<int> chain;  // bodies after the base, base to flange
  for (int b = flange; b != base; b = m->body_parentid[b]) {
    if (b <= 0) throw InputError(path, "body '" + bodyName(m, flange) + "' is not below base body '" + s.base_link + "'");
    chain.push_back(b);
  }
  std::reverse(chain.begin(), chain.end());
  auto onChain = [&](int b) { return std::find(chain.begin(), chain.end(), b) != chain.end(); };

  // A body's collision geoms and inertia, in the frame T places it in.
  auto collect = [&](int b, const Pose& T, LinkSpec& out, arm_builder::Inertia& inertia) {
    arm_builder::Inertia in;
    in.mass = m->body_mass[b];
    in.com = Vec3(m->body_ipos[3 * b], m->body_ipos[3 * b + 1], m->body_ipos[3 * b + 2]);
    const mjtNum* iq = m->body_iquat + 4 * b;
    const Mat3 R = Quat(iq[0], iq[1], iq[2], iq[3]).normalized().toRotationMatrix();
    in.I = R * Vec3(m->body_inertia[3 * b], m->body_inertia[3 * b + 1], m->body_inertia[3 * b + 2]).asDiagonal() * R.transpose();
    arm_builder::addInertia(inertia, in, T);
    for (int g = m->body_geomadr[b]; g >= 0 && g < m->body_geomadr[b] + m->body_geomnum[b]; ++g) {
      if (m->geom_contype[g] == 0 && m->geom_conaffinity[g] == 0) continue;  // visual only
      const mjtNum* gp = m->geom_pos + 3 * g;
      const mjtNum* gq = m->geom_quat + 4 * g;
      const Pose Tg = T * makePose(Vec3(gp[0], gp[1], gp[2]), Quat(gq[0], gq[1], gq[2], gq[3]).normalized());
      const mjtNum* size = m->geom_size + 3 * g;
      ShapeSpec sh;
      switch (m->geom_type[g]) {
        case mjGEOM_SPHERE:
          sh.type = ShapeSpec::Type::kSphere;
          sh.pos = arm_builder::arr(Tg.translation());
          sh.radius = size[0];
          break;
        case mjGEOM_CAPSULE:
        case mjGEOM_CYLINDER: {
          sh.type = m->geom_type[g] == mjGEOM_CAPSULE ? ShapeSpec::Type::kCapsule : ShapeSpec::Type::kCylinder;
          const Vec3 half = Tg.linear().col(2) * size[1];
          sh.from = arm_builder::arr(Tg.translation() - half);
          sh.to = arm_builder::arr(Tg.translation() + half);
          sh.radius = size[0];
          break;
        }
        case mjGEOM_BOX: {
          sh.type = ShapeSpec::Type::kBox;
          sh.pos = arm_builder::arr(Tg.translation());
          sh.half = {size[0], size[1], size[2]};
          const Quat q(Tg.linear());
          sh.quat = {q.w(), q.x(), q.y(), q.z()};
          break;
        }
        case mjGEOM_MESH: {  // MuJoCo's compiled vertices (in the geom's frame), colliding as their hull
          const int id = m->geom_dataid[g];
          std::vector<Vec3> v;
          for (int i = 0; i < m->mesh_vertnum[id]; ++i) {
            const float* p = m->mesh_vert + 3 * (m->mesh_vertadr[id] + i);
            v.emplace_back(p[0], p[1], p[2]);
          }
          sh.type = ShapeSpec::Type::kMesh;
          sh.mesh = meshCacheFile(v);
          sh.pos = arm_builder::arr(Tg.translation());
          const Quat q(Tg.linear());
          sh.quat = {q.w(), q.x(), q.y(), q.z()};
          break;
        }
        default:
          throw InputError(path, "body '" + bodyName(m, b) + "': collision geom " + std::to_string(g) +
                                     " is not a sphere, capsule, cylinder, box or mesh");
      }
      out.shapes.push_back(sh);
    }
  };
  std::function<void(int, const Pose&, LinkSpec&, arm_builder::Inertia&)> gather = [&](int b, const Pose& T, LinkSpec& out,
                                                                                        arm_builder::Inertia& inertia) {
    collect(b, T, out, inertia);
    if (b == flange) return;  // what hangs below the flange is the gripper's place
    for (int c : children(b)) {
      if (onChain(c)) continue;
      if (slides(c) && !movesBelow(c)) {
        s.notes.push_back("body '" + bodyName(m, c) + "' slides off the arm's chain (a hand's part): left out");
        continue;
      }
      if (hasHinge(c) || movesBelow(c))
        throw InputError(path, "body '" + bodyName(m, c) + "' moves but is not on the arm's chain " + s.base_link + " -> " +
                                   bodyName(m, flange) + " (name the arm's bodies with base_link and flange_link in " + comp.path + ")");
      gather(c, T * bodyPose(m, c), out, inertia);
    }
  };

  LinkSpec current;
  current.name = s.base_link;
  arm_builder::Inertia current_inertia;
  gather(base, Pose::Identity(), current, current_inertia);
  Pose T_acc = Pose::Identity();
  std::vector<int> arm_joints;
  for (int b : chain) {
    const Pose T_origin = T_acc * bodyPose(m, b);
    if (m->body_jntnum[b] == 0) {
      gather(b, T_origin, current, current_inertia);
      T_acc = T_origin;
      continue;
    }
    const int j = m->body_jntadr[b];
    if (m->body_jntnum[b] != 1 || m->jnt_type[j] != mjJNT_HINGE)
      throw InputError(path, "body '" + bodyName(m, b) + "' on the arm's chain must hold one hinge joint (or none)");
    const mjtNum* anchor = m->jnt_pos + 3 * j;
    if (Vec3(anchor[0], anchor[1], anchor[2]).norm() > 1e-9)
      throw InputError(path, "joint '" + std::string(mj_id2name(m, mjOBJ_JOINT, j) ? mj_id2name(m, mjOBJ_JOINT, j) : "?") +
                                 "': its anchor is away from its body's origin (expected pos 0 0 0)");
    arm_builder::addLink(s, current, current_inertia, path, comp);
    JointSpec js;
    js.name = mj_id2name(m, mjOBJ_JOINT, j) ? mj_id2name(m, mjOBJ_JOINT, j) : "";
    if (js.name.empty()) throw InputError(path, "the joint of body '" + bodyName(m, b) + "' needs a name");
    js.xyz = arm_builder::arr(T_origin.translation());
    js.rpy = arm_builder::rpyOf(T_origin.linear());
    const mjtNum* ax = m->jnt_axis + 3 * j;
    js.axis = arm_builder::arr(Vec3(ax[0], ax[1], ax[2]).normalized());
    if (m->jnt_limited[j]) js.lower = m->jnt_range[2 * j], js.upper = m->jnt_range[2 * j + 1];
    else js.lower = -2 * M_PI, js.upper = 2 * M_PI;
    if (!(js.lower < js.upper)) throw InputError(path, "joint '" + js.name + "': expected range lower < upper");
    if (std::abs(m->qpos0[m->jnt_qposadr[j]]) > 1e-12)
      throw InputError(path, "joint '" + js.name + "': a reference position (ref) other than 0 is not supported");
    // The torque limit: the joint's one motor — |gear| x forcerange, or |gear| x ctrlrange for a
    // plain motor (fixed unit gain, no bias) — else the companion's effort.
    int motors = 0;
    for (int a = 0; a < m->nu; ++a) {
      if (m->actuator_trntype[a] != mjTRN_JOINT || m->actuator_trnid[2 * a] != j) continue;
      ++motors;
      const double gear = std::abs(m->actuator_gear[6 * a]);
      const bool plain = m->actuator_gaintype[a] == mjGAIN_FIXED && m->actuator_gainprm[mjNGAIN * a] == 1 &&
                         m->actuator_biastype[a] == mjBIAS_NONE;
      if (m->actuator_forcelimited[a])
        js.effort = gear * std::max(std::abs(m->actuator_forcerange[2 * a]), std::abs(m->actuator_forcerange[2 * a + 1]));
      else if (m->actuator_ctrllimited[a] && plain)
        js.effort = gear * std::max(std::abs(m->actuator_ctrlrange[2 * a]), std::abs(m->actuator_ctrlrange[2 * a + 1]));
    }
    if (motors > 1) js.effort = 0;  // several actuators: the companion says
    arm_joints.push_back(j);
    arm_builder::recognizeDh(js);
    s.joints.push_back(js);
    current = LinkSpec{};
    current.name = bodyName(m, b);
    current_inertia = arm_builder::Inertia{};
    T_acc = Pose::Identity();
    gather(b, Pose::Identity(), current, current_inertia);
  }
  arm_builder::addLink(s, current, current_inertia, path, comp);
  // What MJCF does not carry: velocity limits (required), torque limits where no motor says.
  const size_t n = s.joints.size();
  // MJCF carries no velocity limits: a cautious default (below the ratings of the arms we know),
  // said, unless the companion gives the arm's own.
  constexpr double kDefaultVelocity = 1.5;  // [rad/s]
  if (!y["velocity"])
    s.notes.push_back("MJCF has no joint velocity limits: " + std::to_string(kDefaultVelocity).substr(0, 3) +
                      " rad/s each assumed (give the arm's own as velocity in " + comp.path + ")");
  const auto vel = comp.perJoint("velocity", n, kDefaultVelocity, true);
  const auto eff = comp.perJoint("effort", n, 0.0, true);
  for (size_t i = 0; i < n; ++i) {
    s.joints[i].velocity = vel[i];
    if (y["effort"]) s.joints[i].effort = eff[i];
    if (!(s.joints[i].effort > 0))
      throw InputError(path, "joint '" + s.joints[i].name + "': no torque limit (a motor with ctrlrange or forcerange, or effort in " + comp.path + ")");
  }
  // The file's own home: its keyframe 'home', the arm's joints' entries (a hand's beyond them ignored).
  std::vector<double> file_home;
  if (const int key = mj_name2id(m, mjOBJ_KEY, "home"); key >= 0)
    for (int j : arm_joints) file_home.push_back(m->key_qpos[key * m->nq + m->jnt_qposadr[j]]);
  arm_builder::finishArm(s, comp, T_acc, gripper_yaml, path, file_home);
  return s;
}

}  // namespace

namespace {

// The robot file as the harness reads it: what changes the model's meaning is kept (its bodies,
// joints, geoms, meshes, actuators, keyframes, and the compiler settings angle, eulerseq, meshdir,
// texturedir, assetdir, autolimits and the inertia ones); what only tunes a simulation of its own
// (<option>, <size>, <visual>, <statistic>, <extension>, other compiler settings) is left out —
// the scene sets those — and said in `notes`. `lines` maps a line of the text returned to the
// file's own line (MuJoCo's errors name lines of what it read).
std::string mjcfAsRead(const std::string& path, std::vector<std::string>& notes, std::vector<int>& lines) {
  tinyxml2::XMLDocument doc;
  if (doc.LoadFile(path.c_str()) != tinyxml2::XML_SUCCESS) throw InputError(path, "cannot read the MJCF robot");
  tinyxml2::XMLElement* root = doc.RootElement();
  if (!root) throw InputError(path, "expected a <mujoco> root element");
  static const std::set<std::string> kLeftOut = {"option", "size", "visual", "statistic", "extension"};
  static const std::set<std::string> kCompilerKept = {"angle", "eulerseq", "meshdir", "texturedir", "assetdir", "autolimits",
                                                      "coordinate", "inertiafromgeom", "inertiagrouprange", "boundmass",
                                                      "boundinertia", "balanceinertia", "settotalmass", "fitaabb",
                                                      "exactmeshinertia", "strippath", "convexhull", "discardvisual"};
  std::vector<tinyxml2::XMLElement*> drop;
  for (tinyxml2::XMLElement* e = root->FirstChildElement(); e; e = e->NextSiblingElement()) {
    const std::string tag = e->Name();
    if (kLeftOut.count(tag)) {
      drop.push_back(e);
      notes.push_back("its <" + tag + "> (line " + std::to_string(e->GetLineNum()) + ") is left out: the scene sets the simulation's own");
    } else if (tag == "compiler") {
      std::vector<std::string> gone;
      for (const tinyxml2::XMLAttribute* a = e->FirstAttribute(); a; a = a->Next())
        if (!kCompilerKept.count(a->Name())) gone.push_back(a->Name());
      for (const auto& g : gone) {
        e->DeleteAttribute(g.c_str());
        notes.push_back("its <compiler " + g + "> (line " + std::to_string(e->GetLineNum()) + ") is left out");
      }
    }
  }
  for (auto* e : drop) root->DeleteChild(e);
  std::vector<int> original;  // elements in document order, their lines in the file
  std::function<void(const tinyxml2::XMLElement*, std::vector<int>&)> walk = [&](const tinyxml2::XMLElement* e, std::vector<int>& out) {
    out.push_back(e->GetLineNum());
    for (const auto* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) walk(c, out);
  };
  walk(root, original);
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  const std::string text = printer.CStr();
  tinyxml2::XMLDocument again;  // what tinyxml2 printed reads back, but for text it cannot print again
  std::vector<int> printed;
  if (again.Parse(text.c_str()) == tinyxml2::XML_SUCCESS && again.RootElement()) walk(again.RootElement(), printed);
  for (size_t k = 0; k < printed.size() && k < original.size(); ++k) {
    if (static_cast<int>(lines.size()) <= printed[k]) lines.resize(printed[k] + 1, 0);
    lines[printed[k]] = original[k];
  }
  return text;
}

}  // namespace

RobotSpec loadAnyRobotSpec(const std::string& path, const std::string& gripper_yaml) {
  if (std::filesystem::path(path).extension() != ".xml") return loadRobotSpec(path, gripper_yaml);
  installMujocoHandlers();
  checkMjcf(path);
  std::vector<std::string> notes;
  std::vector<int> lines;
  const std::string xml = mjcfAsRead(path, notes, lines);
  char err[1024] = "";
  mjModel* m = nullptr;
  {
    // Read from memory (MuJoCo's virtual file system) under a name in the file's folder, so its
    // relative paths (meshdir, includes) resolve as they would for the file itself.
    auto vfs = std::make_unique<mjVFS>();
    mj_defaultVFS(vfs.get());
    const std::string vpath = (std::filesystem::path(path).parent_path() / "minimanip_robot_as_read.xml").string();
    if (mj_makeEmptyFileVFS(vfs.get(), vpath.c_str(), static_cast<int>(xml.size())) != 0)
      throw InputError(path, "cannot read the robot in MuJoCo's virtual file system");
    std::memcpy(vfs->filedata[mj_findFileVFS(vfs.get(), vpath.c_str())], xml.data(), xml.size());
    try {
      m = mj_loadXML(vpath.c_str(), vfs.get(), err, sizeof err);
    } catch (const std::runtime_error& e) {
      mj_deleteVFS(vfs.get());
      throw InputError(path, std::string("MuJoCo rejected the robot: ") + e.what());
    }
    mj_deleteVFS(vfs.get());
  }
  if (!m) {
    // MuJoCo names a line of what it read: the file's own line instead, and a keyword newer than
    // MuJoCo 2.2 with its way out.
    std::string msg = err;
    std::string where = path;
    std::smatch hit;
    if (std::regex_search(msg, hit, std::regex("line (\\d+)"))) {
      const int l = std::stoi(hit[1]);
      if (l > 0 && l < static_cast<int>(lines.size()) && lines[l] > 0) {
        where = path + ":" + std::to_string(lines[l]);
        msg = std::regex_replace(msg, std::regex("line \\d+"), "line " + std::to_string(lines[l]));
      }
    }
    for (char& c : msg)
      if (c == '\n') c = ' ';
    static const std::vector<std::pair<std::string, std::string>> kNewer = {
        {"'kv'", "<position kv> is MuJoCo 2.3's: remove kv (the harness drives the arm with its own controller)"},
        {"'dampratio'", "dampratio is MuJoCo 3's: remove it"},
        {"'inheritrange'", "inheritrange is MuJoCo 2.3's: give ctrlrange instead"},
        {"'frame'", "<frame> is MuJoCo 3's: move its children into the enclosing body with the frame's pos and quat"},
        {"'replicate'", "<replicate> is MuJoCo 3's: write the copies out"},
    };
    for (const auto& [word, fix] : kNewer)
      if (msg.find(word) != std::string::npos) msg += " (MuJoCo 2.2 lacks it: " + fix + ")";
    throw InputError(where, "MuJoCo rejected the robot: " + msg);
  }
  try {
    RobotSpec s = readMjcfArm(path, m, gripper_yaml);
    s.notes.insert(s.notes.begin(), notes.begin(), notes.end());
    mj_deleteModel(m);
    return s;
  } catch (...) {
    mj_deleteModel(m);
    throw;
  }
}

RobotModel loadAnyRobot(const std::string& path, const std::string& gripper_yaml) {
  return RobotModel::fromSpec(loadAnyRobotSpec(path, gripper_yaml));
}

}  // namespace mm
