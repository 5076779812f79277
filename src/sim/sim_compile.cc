// A SimWorld's model: the scene with the robot mounted and the trial's objects, composed and
// compiled from memory, checked for what the harness needs, and the physics options applied.
#include <algorithm>
#include <atomic>
#include <cstring>
#include <filesystem>
#include <regex>
#include <sstream>

#include "core/error.h"
#include "sim/mjcf_check.h"
#include "sim/scene_compose.h"
#include "sim/sim_world_impl.h"

namespace mm {

namespace {

// What distinguishes one object list's model from another's.
std::string objectsKey(const std::vector<ObjectKind>& objects) {
  std::string key;
  char buf[400];
  for (const ObjectKind& o : objects) {
    std::snprintf(buf, sizeof buf, "%s|%s|%.17g %.17g %.17g|%.17g|%.17g %.17g %.17g|%d|%.9g %.9g %.9g %.9g;", o.name.c_str(), shapeName(o.shape),
                  o.half_size.x(), o.half_size.y(), o.half_size.z(), o.mass, o.friction[0], o.friction[1], o.friction[2],
                  o.condim, o.rgba[0], o.rgba[1], o.rgba[2], o.rgba[3]);
    key += buf;
    if (o.shape == ObjectShape::kMesh) {
      size_t vertices = 0;
      for (const ConvexPiece& piece : *o.solid->pieces) vertices += piece.vertices.size();
      const ObjectSolid& so = *o.solid;
      std::snprintf(buf, sizeof buf, "%.17g %.17g %.17g|%zu %zu %zu|%.17g|%.17g %.17g %.17g|%.17g %.17g %.17g %.17g %.17g %.17g;", o.scale.x(),
                    o.scale.y(), o.scale.z(), so.pieces->size(), vertices, so.visual_faces.size(), so.volume, so.com.x(), so.com.y(), so.com.z(),
                    so.inertia(0, 0), so.inertia(1, 1), so.inertia(2, 2), so.inertia(0, 1), so.inertia(0, 2), so.inertia(1, 2));
      key += o.mesh + "|" + buf;
    }
  }
  return key;
}

}  // namespace

void PhysicsOptions::declare(ConfigArchive& a) {
  a.value("timestep", timestep, {0, kControlPeriod}, "s",
          "physics timestep; 0: the scene's. It must divide the control period (2 ms, 500 Hz), which stays the same: "
          "the servo's torques are held through the substeps");
  // Not RK4: the servo computes its torques between mj_step1 and mj_step2 (from the current state's
  // inertia), and MuJoCo runs that split step with Euler whatever the option says.
  a.choice("integrator", integrator, {"scene", "Euler", "implicit"},
           "MuJoCo's integrator; scene: the scene's (RK4 is not offered: MuJoCo's split step, which the servo needs, runs it as Euler)");
  a.choice("cone", cone, {"scene", "pyramidal", "elliptic"}, "MuJoCo's friction cone; scene: the scene's");
  a.choice("jacobian", jacobian, {"scene", "dense", "sparse", "auto"}, "MuJoCo's constraint Jacobian; scene: the scene's");
  a.choice("solver", solver, {"scene", "PGS", "CG", "Newton"}, "MuJoCo's constraint solver; scene: the scene's");
  a.value("iterations", iterations, {0, 1000}, "", "the solver's maximum iterations; 0: the scene's");
  a.value("tolerance", tolerance, {-1, 1}, "", "the solver's tolerance (0: run all iterations); -1: the scene's");
  a.value("noslip_iterations", noslip_iterations, {-1, 1000}, "", "MuJoCo's no-slip iterations; -1: the scene's");
  a.value("velocity_product", velocity_product,
          "add to each contact's reference acceleration the velocity-product term (J'q') MuJoCo 2.2 leaves out, "
          "so that friction holds an object on a swinging arm instead of letting it creep along the pads");
  a.value("midphase", midphase,
          "skip the narrow-phase tests of pairs with a box that a cheap bound proves apart (the box against the other's "
          "bounding sphere, two boxes' separating axes): the same contacts, fewer tests (MuJoCo 2.2 has no mid-phase)");
  a.value("sleep", sleep,
          "objects at rest on the static world alone (under 0.5 mm/s and 5 mrad/s for 0.1 s, their contacts with static geoms "
          "within 25 degrees of vertical) with nothing moving within 2 cm sleep: out of collision, held still, until the robot, "
          "an obstacle or a moving object comes that near (MuJoCo 2.2 has no sleeping)");
}

void SimWorld::applyPhysics(Impl& I, const PhysicsOptions& p, const std::string& file) {
  mjOption& o = I.m->opt;
  o = I.scene_option;
  if (p.timestep > 0) o.timestep = p.timestep;
  auto pick = [](const std::string& v, std::initializer_list<std::pair<const char*, int>> names, int keep) {
    for (const auto& [n, value] : names)
      if (v == n) return value;
    return keep;
  };
  o.integrator = pick(p.integrator, {{"Euler", mjINT_EULER}, {"implicit", mjINT_IMPLICIT}}, o.integrator);
  o.cone = pick(p.cone, {{"pyramidal", mjCONE_PYRAMIDAL}, {"elliptic", mjCONE_ELLIPTIC}}, o.cone);
  o.jacobian = pick(p.jacobian, {{"dense", mjJAC_DENSE}, {"sparse", mjJAC_SPARSE}, {"auto", mjJAC_AUTO}}, o.jacobian);
  o.solver = pick(p.solver, {{"PGS", mjSOL_PGS}, {"CG", mjSOL_CG}, {"Newton", mjSOL_NEWTON}}, o.solver);
  if (p.iterations > 0) o.iterations = p.iterations;
  if (p.tolerance >= 0) o.tolerance = p.tolerance;
  if (p.noslip_iterations >= 0) o.noslip_iterations = p.noslip_iterations;
  I.velocity_product = p.velocity_product;
  I.midphase = p.midphase;
  if (I.sleep && !p.sleep) I.wakeAll();
  I.sleep = p.sleep;
  const double n = kControlPeriod / o.timestep;
  if (!(o.timestep > 0) || std::abs(n - std::round(n)) > 1e-9 * n) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "physics timestep %g s does not divide the control period %g s (500 Hz): expected 0.002, 0.001, 0.0005, ...",
                  o.timestep, kControlPeriod);
    throw InputError(file, buf);
  }
  I.substeps = static_cast<int>(std::lround(n));
}

void SimWorld::setPhysics(const PhysicsOptions& physics, const std::string& file) {
  shared_->physics = physics;
  shared_->physics_file = file;
  for (auto& [key, model] : shared_->models) applyPhysics(*model, physics, file);
}

int SimWorld::modelsCompiled() const { return static_cast<int>(shared_->models.size()); }

void SimWorld::setObjects(const std::vector<ObjectKind>& objects) {
  Shared& S = *shared_;
  const std::string key = objectsKey(objects);
  auto it = S.models.find(key);
  if (it == S.models.end()) {
    it = S.models.emplace(key, compile(S, objects)).first;
    applyPhysics(*it->second, S.physics, S.physics_file.empty() ? S.scene_xml : S.physics_file);
  }
  if (impl_ == it->second.get()) return;
  impl_ = it->second.get();
  impl_->ctrl_log = S.ctrl_log;
  reset(S.home);
}

namespace {

// MuJoCo names a line of the composed model. When that line is one of the robot's elements (a
// body, joint or geom the robot's file named), the robot's file is the place to look, with the
// element; else the scene's.
std::string robotOrScene(const std::string& composed, const char* err, const RobotSpec& robot, const std::string& scene_xml) {
  std::smatch hit;
  const std::string msg = err;
  const std::vector<std::string> names = robot.names();
  auto robots = [&](const std::string& name) { return std::find(names.begin(), names.end(), name) != names.end(); };
  // A compile error names its object ("Object name = <name>, id = 2, line = 29").
  if (std::regex_search(msg, hit, std::regex("Object name = ([^,\\s]+)")) && robots(hit[1].str()))
    return robot.file + ": '" + hit[1].str() + "'";
  // A schema error names its element and line ("Element 'joint', line 40").
  if (!std::regex_search(msg, hit, std::regex("line =? ?(\\d+)"))) return scene_xml;
  const int line = std::stoi(hit[1]);
  std::istringstream in(composed);
  std::string text;
  for (int k = 0; k < line && std::getline(in, text); ++k) {
  }
  std::smatch tag;
  if (!std::regex_search(text, tag, std::regex("<(\\w+)[^>]*\\bname=\"([^\"]*)\""))) return scene_xml;
  if (!robots(tag[2].str())) return scene_xml;
  return robot.file + ": <" + tag[1].str() + " name=\"" + tag[2].str() + "\">";
}

}  // namespace

std::unique_ptr<SimWorld::Impl> SimWorld::compile(const Shared& S, const std::vector<ObjectKind>& objects) {
  const std::string& scene_xml = S.scene_xml;
  auto impl = std::make_unique<Impl>();
  Impl& I = *impl;
  // The scene with the robot mounted, compiled from memory (MuJoCo's virtual file system).
  const std::string xml = composeScene(scene_xml, S.spec, objects);
  char err[1024] = "";
  {
    auto vfs = std::make_unique<mjVFS>();
    mj_defaultVFS(vfs.get());
    // Named in the scene's folder, so the scene's relative asset paths (meshes, textures) resolve
    // as they would for the file itself.
    const std::string vpath = (std::filesystem::path(scene_xml).parent_path() / "minimanip_composed_scene.xml").string();
    const char* vname = vpath.c_str();
    if (mj_makeEmptyFileVFS(vfs.get(), vname, static_cast<int>(xml.size())) != 0)
      throw InputError(scene_xml, "cannot compose the scene in MuJoCo's virtual file system");
    std::memcpy(vfs->filedata[mj_findFileVFS(vfs.get(), vname)], xml.data(), xml.size());
    try {
      I.m = mj_loadXML(vname, vfs.get(), err, sizeof err);
    } catch (const std::runtime_error& e) {
      mj_deleteVFS(vfs.get());
      throw InputError(scene_xml, std::string("MuJoCo rejected the scene with ") + S.spec.name + " mounted: " + e.what());
    }
    mj_deleteVFS(vfs.get());
  }
  if (!I.m) {
    std::string what = err;
    std::replace(what.begin(), what.end(), '\n', ' ');
    const std::string where = robotOrScene(xml, err, S.spec, scene_xml);
    if (where != scene_xml) throw InputError(where, "MuJoCo rejected the robot (mounted in " + scene_xml + "): " + what);
    throw InputError(scene_xml, "MuJoCo rejected the scene with " + S.spec.name + " mounted: " + what);
  }
  static std::atomic<uint64_t> serials{0};
  I.serial = ++serials;
  I.d = mj_makeData(I.m);
  I.scene_option = I.m->opt;
  mjModel* m = I.m;
  const RobotSpec& spec = S.spec;
  auto need = [&](mjtObj type, const std::string& name, const char* what) {
    const int id = mj_name2id(m, type, name.c_str());
    if (id < 0) throw InputError(scene_xml, std::string("expected ") + what + " '" + name + "' (from " + spec.file + ")");
    return id;
  };
  I.dof = static_cast<int>(S.joint_names.size());
  for (int i = 0; i < I.dof; ++i) {
    const int j = need(mjOBJ_JOINT, S.joint_names[i], "a joint");
    I.arm_qpos.push_back(m->jnt_qposadr[j]);
    I.arm_dof.push_back(m->jnt_dofadr[j]);
    I.arm_act.push_back(need(mjOBJ_ACTUATOR, S.joint_names[i], "an actuator"));
    I.effort.push_back(spec.joints[i].effort);
  }
  for (int k = 0; k < 2; ++k) {
    const std::string& name = spec.gripper.finger_joints[k];
    const int j = need(mjOBJ_JOINT, name, "a finger joint");
    I.finger_qpos[k] = m->jnt_qposadr[j];
    I.finger_dof[k] = m->jnt_dofadr[j];
    I.finger_act[k] = need(mjOBJ_ACTUATOR, name, "a finger actuator");
  }
  I.finger_vmax = spec.gripper.velocity;
  I.tcp_site = need(mjOBJ_SITE, spec.tip_link, "a TCP site");
  I.robot_root = need(mjOBJ_BODY, spec.base_link, "a robot base body");
  for (int k = 0;; ++k) {
    const std::string name = "object_" + std::to_string(k);
    const int b = mj_name2id(m, mjOBJ_BODY, name.c_str());
    if (b < 0) break;
    // The geoms that collide first — one box or cylinder, or a mesh object's convex pieces —
    // then any only drawn.
    std::vector<int> colliders;
    bool ordered = true;
    for (int g = m->body_geomadr[b]; g < m->body_geomadr[b] + m->body_geomnum[b]; ++g) {
      const bool collides = m->geom_contype[g] != 0 || m->geom_conaffinity[g] != 0;
      if (collides && colliders.size() != static_cast<size_t>(g - m->body_geomadr[b])) ordered = false;
      if (collides) colliders.push_back(g);
    }
    const int t = m->body_geomnum[b] > 0 ? m->geom_type[m->body_geomadr[b]] : -1;
    bool pieces = true;
    for (int g : colliders) pieces = pieces && m->geom_type[g] == mjGEOM_MESH;
    if (m->body_jntnum[b] != 1 || m->jnt_type[m->body_jntadr[b]] != mjJNT_FREE || colliders.empty() || !ordered ||
        (t != mjGEOM_BOX && t != mjGEOM_CYLINDER && t != mjGEOM_MESH) || (colliders.size() > 1 && !pieces))
      throw InputError(scene_xml, "object body '" + name + "' must have one free joint and one box, cylinder or mesh geom (or mesh pieces)");
    I.obj_colliders.push_back(colliders);
    I.obj_body.push_back(b);
    I.obj_qpos.push_back(m->jnt_qposadr[m->body_jntadr[b]]);
    I.obj_dof.push_back(m->jnt_dofadr[m->body_jntadr[b]]);
    I.obj_geom.push_back(m->body_geomadr[b]);
    const int eq = mj_name2id(m, mjOBJ_EQUALITY, ("attach_" + std::to_string(k)).c_str());
    I.obj_weld.push_back(eq);
  }
  // Park poses: five to a row along the object_park site's x, rows along its y, resting on its
  // plane; without the site, far below the scene (where a parked object falls, touching nothing).
  mj_kinematics(m, I.d);
  const int park = mj_name2id(m, mjOBJ_SITE, "object_park");
  const Pose T_park = park >= 0 ? poseOf(I.d->site_xpos + 3 * park, I.d->site_xmat + 9 * park) : makePose(Vec3(0, 0, -100), Mat3::Identity());
  for (size_t k = 0; k < I.obj_body.size(); ++k) {
    const double hz = objects[k].half_size.z();
    if (objects[k].shape == ObjectShape::kMesh) {
      // Its <inertial> must be what MuJoCo kept (a robot's <compiler inertiafromgeom="true"> would
      // make it the geoms' at density 1000, silently), and its drawn mesh must be there.
      const int b = I.obj_body[k];
      const bool drawn = m->body_geomnum[b] == static_cast<int>(objects[k].solid->pieces->size()) + 1;
      if (std::abs(m->body_mass[b] - objects[k].mass) > 1e-9 * std::max(1.0, objects[k].mass) || !drawn)
        throw InputError(objects[k].mesh, std::string("object kind '") + objects[k].name + "': the compiled model " +
                                              (drawn ? "weighs " + std::to_string(m->body_mass[b]) + " kg, not its " + std::to_string(objects[k].mass)
                                                     : "lost its drawn mesh") +
                                              " (a <compiler> setting of the robot's: inertiafromgeom or discardvisual?)");
    }
    I.obj_pieces.push_back(objects[k].shape == ObjectShape::kMesh ? objects[k].solid->pieces : nullptr);
    I.obj_half.push_back(objects[k].half_size);
    I.obj_park.push_back(T_park * makePose(Vec3(0.1 * static_cast<double>(k % 5), 0.1 * static_cast<double>(k / 5), hz + 0.001), Mat3::Identity()));
  }
  for (int k = 0;; ++k) {
    const std::string name = "obstacle_" + std::to_string(k);
    const int b = mj_name2id(m, mjOBJ_BODY, name.c_str());
    if (b < 0) break;
    if (m->body_mocapid[b] < 0 || m->body_geomnum[b] != 1 || m->geom_type[m->body_geomadr[b]] != mjGEOM_BOX)
      throw InputError(scene_xml, "obstacle body '" + name + "' must be a mocap body with one box geom");
    I.obstacle_body.push_back(b);
    I.obstacle_mocap.push_back(m->body_mocapid[b]);
    I.obstacle_geom.push_back(m->body_geomadr[b]);
  }
  I.obstacle_placed.assign(I.obstacle_body.size(), 0);
  I.robot_geom.assign(m->ngeom, 0);
  I.static_geom.assign(m->ngeom, 0);
  I.foreign_geom.assign(m->ngeom, 0);
  for (int g : I.obstacle_geom) I.foreign_geom[g] = 1;
  for (int g = 0; g < m->ngeom; ++g) {
    for (int b = m->geom_bodyid[g]; b > 0; b = m->body_parentid[b])
      if (b == I.robot_root) I.robot_geom[g] = 1;
    // The world's static parts: on the world body, or on a body welded to it (a moved mount puts
    // the scene in one such frame body); not the robot's, not a mocap body's.
    bool mocap = false;  // a mocap body or one fixed to it moves
    for (int b = m->geom_bodyid[g]; b > 0 && !mocap; b = m->body_parentid[b]) mocap = m->body_mocapid[b] >= 0;
    if (!I.robot_geom[g] && !mocap && m->body_weldid[m->geom_bodyid[g]] == 0)
      I.static_geom[g] = m->geom_type[g] != mjGEOM_PLANE;  // the floor is out of reach
  }
  I.geom_object.assign(m->ngeom, -1);
  for (size_t i = 0; i < I.obj_body.size(); ++i)  // its collision geom and any drawn ones
    for (int g = m->body_geomadr[I.obj_body[i]]; g < m->body_geomadr[I.obj_body[i]] + m->body_geomnum[I.obj_body[i]]; ++g)
      I.geom_object[g] = static_cast<int>(i);
  I.initSleep();
  I.geom_label.assign(m->ngeom, kSegmentScene);
  for (int g = 0; g < m->ngeom; ++g) {
    if (I.robot_geom[g]) I.geom_label[g] = kSegmentRobot;
    else if (I.foreign_geom[g]) I.geom_label[g] = kSegmentObstacle;
    else if (I.geom_object[g] >= 0) I.geom_label[g] = static_cast<unsigned char>(kSegmentObject0 + std::min(I.geom_object[g], 252));
  }
  // Force groups: the hand is the body the fingers hang from; it, the fingers and anything mounted
  // below it sense contact as one (a wrist force sensor's view); every other arm body on its own.
  const int hand = m->body_parentid[m->jnt_bodyid[m->dof_jntid[I.finger_dof[0]]]];
  I.hand_body = hand;
  I.body_group.assign(m->nbody, -1);
  for (int b = 1; b < m->nbody; ++b) {
    int group = -1;
    for (int a = b; a > 0; a = m->body_parentid[a]) {
      if (a == hand) group = hand;
      if (a == I.robot_root) {
        I.body_group[b] = group >= 0 ? group : b;
        break;
      }
    }
  }
  I.scratch_a.resize(m->nv);
  I.scratch_b.resize(m->nv);
  return impl;
}

void SimWorld::setStiff(bool on) { impl_->stiff = on; }


}  // namespace mm
