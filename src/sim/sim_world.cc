#include "sim/sim_world.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/error.h"
#include "sim/midphase.h"
#include "sim/mjcf_check.h"
#include "sim/scene_compose.h"
#include "sim/sim_world_impl.h"

namespace mm {
namespace {


// MuJoCo's default error handler waits on stdin and writes MUJOCO_LOG.TXT. Ours must not return
// (MuJoCo's state is undefined after mju_error) and must not unwind through MuJoCo's C frames (no
// exception, no longjmp): it says what happened and ends the process. In a campaign that process is
// a worker: the supervisor retries the trial in a fresh worker, then records it as a crash.
// (Loading never gets here: mj_loadXML reports its errors in a buffer.)
void onMujocoError(const char* msg) {
  std::fprintf(stderr, "minimanip: MuJoCo error: %s\n", msg);
  std::fflush(stderr);
  std::abort();
}
void onMujocoWarning(const char* msg) { lastMujocoWarning() = msg; }

}  // namespace

void installMujocoHandlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    mju_user_error = onMujocoError;
    mju_user_warning = onMujocoWarning;
  });
  installMidphase();
}

std::string& lastMujocoWarning() {
  thread_local std::string last;
  return last;
}

Pose poseOf(const mjtNum* pos, const mjtNum* mat) {
  Pose T = Pose::Identity();
  for (int r = 0; r < 3; ++r) {
    T.translation()[r] = pos[r];
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = mat[3 * r + c];
  }
  return T;
}




SimWorld::SimWorld() : shared_(std::make_unique<Shared>()) {}
SimWorld::~SimWorld() = default;

std::unique_ptr<SimWorld> SimWorld::load(const std::string& scene_xml, const RobotModel& robot,
                                         const std::vector<ObjectKind>& objects) {
  installMujocoHandlers();
  checkMjcf(scene_xml);
  std::unique_ptr<SimWorld> w(new SimWorld());
  Shared& S = *w->shared_;
  S.scene_xml = scene_xml;
  S.spec = robot.spec();
  S.joint_names = robot.jointNames();
  S.home = robot.home();
  w->setObjects(objects);
  return w;
}


void SimWorld::setPayload(double mass, const Vec3& com_tcp) {
  impl_->payload_mass = mass;
  impl_->payload_tcp = com_tcp;
}

void SimWorld::reset(const VecX& q_arm) {
  Impl& I = *impl_;
  I.stiff = false;
  I.payload_mass = 0;
  I.wakeAll();
  mj_resetData(I.m, I.d);
  for (int i = 0; i < numObjects(); ++i) parkObject(i);
  for (size_t k = 0; k < I.obj_weld.size(); ++k)
    if (I.obj_weld[k] >= 0) I.m->eq_active[I.obj_weld[k]] = 0;
  for (int i = 0; i < I.dof; ++i) I.d->qpos[I.arm_qpos[i]] = q_arm[i];
  setFingers(I.m->jnt_range[2 * I.m->dof_jntid[I.finger_dof[0]] + 1]);
  std::fill(I.obstacle_placed.begin(), I.obstacle_placed.end(), 0);  // mj_resetData parked them
  I.touching.clear();
  I.last_contact_time = -1e9;
  I.collision_events = 0;
  I.collision_log.clear();
  I.unstable = false;
  I.instability.clear();
  I.camera_offsets.clear();
  lastMujocoWarning().clear();
  mj_forward(I.m, I.d);
}

double SimWorld::time() const { return impl_->d->time; }
double SimWorld::timestep() const { return impl_->m->opt.timestep; }
double SimWorld::controlPeriod() const { return kControlPeriod; }
const ServoGains& SimWorld::gains() const { return impl_->gains; }

VecX SimWorld::armPositions() const {
  VecX q(impl_->dof);
  for (int i = 0; i < impl_->dof; ++i) q[i] = impl_->d->qpos[impl_->arm_qpos[i]];
  return q;
}
VecX SimWorld::armVelocities() const {
  VecX v(impl_->dof);
  for (int i = 0; i < impl_->dof; ++i) v[i] = impl_->d->qvel[impl_->arm_dof[i]];
  return v;
}
void SimWorld::setArm(const VecX& q) {
  for (int i = 0; i < impl_->dof; ++i) {
    impl_->d->qpos[impl_->arm_qpos[i]] = q[i];
    impl_->d->qvel[impl_->arm_dof[i]] = 0;
  }
}
double SimWorld::fingerForce() const {
  const auto& I = *impl_;
  return std::max(0.0, -0.5 * (I.d->ctrl[I.finger_act[0]] + I.d->ctrl[I.finger_act[1]]));
}

double SimWorld::fingerOpening() const {
  return 0.5 * (impl_->d->qpos[impl_->finger_qpos[0]] + impl_->d->qpos[impl_->finger_qpos[1]]);
}
void SimWorld::setFingers(double opening) {
  for (int k = 0; k < 2; ++k) {
    impl_->d->qpos[impl_->finger_qpos[k]] = opening;
    impl_->d->qvel[impl_->finger_dof[k]] = 0;
    impl_->finger_ramp[k] = opening;
  }
}
Pose SimWorld::tcpPose() const {
  const int s = impl_->tcp_site;
  return poseOf(impl_->d->site_xpos + 3 * s, impl_->d->site_xmat + 9 * s);
}

int SimWorld::numObjects() const { return static_cast<int>(impl_->obj_body.size()); }

Pose SimWorld::objectDrawnPose(int i) const {
  const Impl& I = *impl_;
  const int b = I.obj_body[i];
  const mjtNum* x = I.d->xpos + 3 * b;
  const mjtNum* q = I.d->xquat + 4 * b;
  return makePose(Vec3(x[0], x[1], x[2]), Quat(q[0], q[1], q[2], q[3]));
}

TriangleMesh SimWorld::objectSurface(int i) const {
  const Impl& I = *impl_;
  const mjModel* m = I.m;
  TriangleMesh out;
  out.part = mj_id2name(m, mjOBJ_BODY, I.obj_body[i]);
  auto add = [&](const std::vector<Vec3>& v, const std::vector<std::array<int, 3>>& f, const Pose& T_body_geom) {
    const int base = static_cast<int>(out.vertices.size());
    for (const Vec3& p : v) out.vertices.push_back(T_body_geom * p);
    for (const auto& t : f) out.faces.push_back({base + t[0], base + t[1], base + t[2]});
  };
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_bodyid[g] != I.obj_body[i] || m->geom_group[g] > 2) continue;  // mjvOption's default: groups 0-2 drawn
    const mjtNum* q = m->geom_quat + 4 * g;
    const Pose T = makePose(Vec3(m->geom_pos[3 * g], m->geom_pos[3 * g + 1], m->geom_pos[3 * g + 2]), Quat(q[0], q[1], q[2], q[3]));
    const mjtNum* s = m->geom_size + 3 * g;
    std::vector<Vec3> v;
    std::vector<std::array<int, 3>> f;
    switch (m->geom_type[g]) {
      case mjGEOM_MESH: {
        const int mesh = m->geom_dataid[g];
        for (int k = 0; k < m->mesh_vertnum[mesh]; ++k) {
          const float* p = m->mesh_vert + 3 * (m->mesh_vertadr[mesh] + k);
          v.emplace_back(p[0], p[1], p[2]);
        }
        for (int k = 0; k < m->mesh_facenum[mesh]; ++k) {
          const int* t = m->mesh_face + 3 * (m->mesh_faceadr[mesh] + k);
          f.push_back({t[0], t[1], t[2]});
        }
        break;
      }
      case mjGEOM_BOX:
        for (int k = 0; k < 8; ++k) v.emplace_back((k & 1 ? 1 : -1) * s[0], (k & 2 ? 1 : -1) * s[1], (k & 4 ? 1 : -1) * s[2]);
        // Two triangles a face, counter-clockwise seen from outside: -x, +x, -y, +y, -z, +z.
        f = {{0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}, {0, 1, 5}, {0, 5, 4},
             {2, 6, 7}, {2, 7, 3}, {0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}};
        break;
      case mjGEOM_CYLINDER: {
        constexpr int n = 64;  // sides: the polygon's edge is within 0.12% of the radius of the circle
        for (int k = 0; k < n; ++k) {
          const double a = 2 * M_PI * k / n;
          v.emplace_back(s[0] * std::cos(a), s[0] * std::sin(a), -s[1]);
          v.emplace_back(s[0] * std::cos(a), s[0] * std::sin(a), s[1]);
        }
        v.emplace_back(0, 0, -s[1]);
        v.emplace_back(0, 0, s[1]);
        for (int k = 0; k < n; ++k) {
          const int a0 = 2 * k, a1 = a0 + 1, b0 = 2 * ((k + 1) % n), b1 = b0 + 1;
          f.push_back({a0, b0, b1});
          f.push_back({a0, b1, a1});
          f.push_back({2 * n, b0, a0});
          f.push_back({2 * n + 1, a1, b1});
        }
        break;
      }
      default:
        throw std::runtime_error(out.part + ": a geom of MuJoCo type " + std::to_string(m->geom_type[g]) +
                                 " has no surface here (objects are boxes, cylinders and meshes)");
    }
    add(v, f, T);
  }
  return out;
}

ObjectState SimWorld::object(int i) const {
  const Impl& I = *impl_;
  ObjectState o;
  o.index = i;
  o.name = mj_id2name(I.m, mjOBJ_BODY, I.obj_body[i]);
  const mjtNum* q = I.d->qpos + I.obj_qpos[i];
  o.T_world_object = makePose(Vec3(q[0], q[1], q[2]), Quat(q[3], q[4], q[5], q[6]));
  const mjtNum* s = I.m->geom_size + 3 * I.obj_geom[i];
  if (I.obj_pieces[static_cast<size_t>(i)]) {
    o.shape = ObjectShape::kMesh;
    o.half_size = I.obj_half[static_cast<size_t>(i)];
    o.pieces = I.obj_pieces[static_cast<size_t>(i)];
  } else if (I.m->geom_type[I.obj_geom[i]] == mjGEOM_CYLINDER) {
    o.shape = ObjectShape::kCylinder;
    o.half_size = Vec3(s[0], s[0], s[1]);
  } else {
    o.half_size = Vec3(s[0], s[1], s[2]);
  }
  o.mass = I.m->body_mass[I.obj_body[i]];
  return o;
}

Vec3 SimWorld::objectVelocity(int i) const {
  const mjtNum* v = impl_->d->qvel + impl_->obj_dof[i];
  return Vec3(v[0], v[1], v[2]);
}

void SimWorld::setObjectPose(int i, const Pose& T) {
  impl_->wake(static_cast<size_t>(i));
  mjtNum* q = impl_->d->qpos + impl_->obj_qpos[i];
  const Quat r(T.linear());
  q[0] = T.translation().x(), q[1] = T.translation().y(), q[2] = T.translation().z();
  q[3] = r.w(), q[4] = r.x(), q[5] = r.y(), q[6] = r.z();
  std::fill(impl_->d->qvel + impl_->obj_dof[i], impl_->d->qvel + impl_->obj_dof[i] + 6, 0.0);
}

void SimWorld::parkObject(int i) { setObjectPose(i, impl_->obj_park[i]); }

void SimWorld::setMocapPose(const std::string& name, const Pose& T) {
  const mjModel* m = impl_->m;
  const int b = mj_name2id(m, mjOBJ_BODY, name.c_str());
  if (b < 0 || m->body_mocapid[b] < 0) throw InputError(name, "the model has no mocap body of this name");
  const int k = m->body_mocapid[b];
  const Quat q(T.linear());
  for (int i = 0; i < 3; ++i) impl_->d->mocap_pos[3 * k + i] = T.translation()[i];
  impl_->d->mocap_quat[4 * k] = q.w(), impl_->d->mocap_quat[4 * k + 1] = q.x();
  impl_->d->mocap_quat[4 * k + 2] = q.y(), impl_->d->mocap_quat[4 * k + 3] = q.z();
  mj_kinematics(m, impl_->d);
}

const mjModel_* SimWorld::mujocoModel() const { return impl_->m; }
mjData_* SimWorld::mujocoData() const { return impl_->d; }
uint64_t SimWorld::modelSerial() const { return impl_->serial; }
const std::vector<unsigned char>& SimWorld::geomLabels() const { return impl_->geom_label; }

int SimWorld::numObstacles() const { return static_cast<int>(impl_->obstacle_body.size()); }

Vec3 SimWorld::obstacleHalfSize(int k) const {
  const mjtNum* s = impl_->m->geom_size + 3 * impl_->obstacle_geom[k];
  return Vec3(s[0], s[1], s[2]);
}

void SimWorld::placeObstacle(int k, const Pose& T) {
  Impl& I = *impl_;
  // The geom's offset in its body is part of the pose asked for: place the body so the geom lands there.
  const int g = I.obstacle_geom[k];
  const Pose T_body_geom = makePose(Vec3(I.m->geom_pos[3 * g], I.m->geom_pos[3 * g + 1], I.m->geom_pos[3 * g + 2]),
                                    Quat(I.m->geom_quat[4 * g], I.m->geom_quat[4 * g + 1], I.m->geom_quat[4 * g + 2], I.m->geom_quat[4 * g + 3]));
  const Pose T_body = T * T_body_geom.inverse();
  const Quat q(T_body.linear());
  mjtNum* p = I.d->mocap_pos + 3 * I.obstacle_mocap[k];
  mjtNum* r = I.d->mocap_quat + 4 * I.obstacle_mocap[k];
  p[0] = T_body.translation().x(), p[1] = T_body.translation().y(), p[2] = T_body.translation().z();
  r[0] = q.w(), r[1] = q.x(), r[2] = q.y(), r[3] = q.z();
  I.obstacle_placed[k] = 1;
  mj_kinematics(I.m, I.d);
}

std::vector<Obstacle> SimWorld::placedObstacles() const {
  const Impl& I = *impl_;
  std::vector<Obstacle> out;
  for (size_t k = 0; k < I.obstacle_body.size(); ++k) {
    if (!I.obstacle_placed[k]) continue;
    const int g = I.obstacle_geom[k];
    Obstacle o;
    o.type = Obstacle::Type::kBox;
    o.size = obstacleHalfSize(static_cast<int>(k));
    o.T_world = poseOf(I.d->geom_xpos + 3 * g, I.d->geom_xmat + 9 * g);
    o.name = mj_id2name(I.m, mjOBJ_BODY, I.obstacle_body[k]);
    out.push_back(o);
  }
  return out;
}

double SimWorld::objectPenetration(int i) const {
  const Impl& I = *impl_;
  mj_fwdPosition(I.m, I.d);
  double worst = 0;
  for (int c = 0; c < I.d->ncon; ++c) {
    const mjContact& con = I.d->contact[c];
    for (int g : I.obj_colliders[i])
      if (con.geom1 == g || con.geom2 == g) worst = std::max(worst, -con.dist);
  }
  return worst;
}

double SimWorld::surfaceBelow(const Vec3& p, int exclude) const {
  const Impl& I = *impl_;
  mj_kinematics(I.m, I.d);
  const mjtNum pnt[3] = {p.x(), p.y(), p.z()};
  const mjtNum dir[3] = {0, 0, -1};
  int geom = -1;
  const int body_exclude = exclude >= 0 ? I.obj_body[exclude] : -1;
  // Only static geoms and other objects count as support (group filter: all groups).
  const mjtNum dist = mj_ray(I.m, I.d, pnt, dir, nullptr, 1, body_exclude, &geom);
  if (dist < 0) return -1e9;
  return p.z() - dist;
}

void SimWorld::stepServo(const VecX& q, const VecX& qd, const VecX& qdd, double finger_target, double finger_force) {
  Impl& I = *impl_;
  if (I.unstable) {  // back where it was good (below): time goes on, nothing moves
    stepKinematic();
    return;
  }
  I.saveGood();
  mjModel* m = I.m;
  mjData* d = I.d;
  setMidphase(I.midphase);
  I.updateSleep();
  mj_step1(m, d);  // positions, velocities, inertia and bias forces at the current state
  // Computed torque: tau = M (qdd + kp e + kd edot) + bias - passive (joint damping), arm rows.
  std::fill(I.scratch_a.begin(), I.scratch_a.end(), 0.0);
  const double kp = I.stiff ? I.gains.stiff_kp : I.gains.kp, kd = I.stiff ? I.gains.stiff_kd : I.gains.kd;
  for (int i = 0; i < I.dof; ++i) {
    const double e = q[i] - d->qpos[I.arm_qpos[i]];
    const double ed = qd[i] - d->qvel[I.arm_dof[i]];
    I.scratch_a[I.arm_dof[i]] = qdd[i] + kp * e + kd * ed;
  }
  mj_mulM(m, d, I.scratch_b.data(), I.scratch_a.data());
  if (I.payload_mass > 0) {
    // The payload the model of the arm does not hold: tau += J_com^T m (a_cmd - g), J_com the
    // translational Jacobian at its centre (fixed in the hand), a_cmd = J_com qdd (the feed-forward).
    const Pose T_tcp = poseOf(d->site_xpos + 3 * I.tcp_site, d->site_xmat + 9 * I.tcp_site);
    const Vec3 p = T_tcp * I.payload_tcp;
    const mjtNum point[3] = {p.x(), p.y(), p.z()};
    I.scratch_jac.resize(3 * static_cast<size_t>(m->nv));
    mj_jac(m, d, I.scratch_jac.data(), nullptr, point, I.hand_body);
    Vec3 a = Vec3::Zero();
    for (int r = 0; r < 3; ++r)
      for (int i = 0; i < I.dof; ++i) a[r] += I.scratch_jac[r * m->nv + I.arm_dof[i]] * qdd[i];
    const Vec3 F = I.payload_mass * (a - Vec3(m->opt.gravity[0], m->opt.gravity[1], m->opt.gravity[2]));
    for (int i = 0; i < I.dof; ++i)
      for (int r = 0; r < 3; ++r) I.scratch_b[I.arm_dof[i]] += I.scratch_jac[r * m->nv + I.arm_dof[i]] * F[r];
  }
  for (int i = 0; i < I.dof; ++i) {
    const double tau = I.scratch_b[I.arm_dof[i]] + d->qfrc_bias[I.arm_dof[i]] - d->qfrc_passive[I.arm_dof[i]];
    d->ctrl[I.arm_act[i]] = std::clamp(tau, -I.effort[i], I.effort[i]);
  }
  // Fingers: a target ramped at the finger speed limit, PD force clamped to the force limit.
  const double dt = kControlPeriod;
  // A new goal starts its ramp where the finger is (bumpless): a release from a squeeze would
  // otherwise first run the ramp back from the closed goal through the object, the fingers still
  // squeezing for 0.12 s, and the gripper, still for 50 ms, would report them done before they let go.
  const bool new_goal = finger_target != I.finger_goal;
  I.finger_goal = finger_target;
  for (int k = 0; k < 2; ++k) {
    if (new_goal) I.finger_ramp[k] = d->qpos[I.finger_qpos[k]];
    const double step = I.finger_vmax * dt;
    double& r = I.finger_ramp[k];
    const double vref = finger_target > r + step ? I.finger_vmax : (finger_target < r - step ? -I.finger_vmax : 0.0);
    r = vref != 0 ? r + vref * dt : finger_target;
    const double f = I.gains.finger_kp * (r - d->qpos[I.finger_qpos[k]]) + I.gains.finger_kd * (vref - d->qvel[I.finger_dof[k]]);
    d->ctrl[I.finger_act[k]] = std::clamp(f, -finger_force, finger_force);
  }
  // The torques held through the period's physics substeps (a digital controller's zero-order hold).
  for (int sub = 0; sub < I.substeps; ++sub) {
    if (I.ctrl_log) I.ctrl_log->insert(I.ctrl_log->end(), d->ctrl, d->ctrl + m->nu);
    try {
      if (sub == 0) {
        I.addVelocityProduct();
        mj_step2(m, d);
      } else {
        I.physicsStep();
      }
    } catch (const std::runtime_error& e) {
      I.unstable = true;
      I.instability = e.what();
    }
    if (!I.unstable) I.monitor();  // contacts found by this step's collision pass (state at the step's start)
    if (I.unstable) {
      I.restoreGood();
      return;
    }
  }
}

void SimWorld::stepKinematic() {
  Impl& I = *impl_;
  I.d->time += kControlPeriod;
  mj_fwdPosition(I.m, I.d);
  I.monitor();
}

void SimWorld::recordControls(std::vector<double>* log) { shared_->ctrl_log = impl_->ctrl_log = log; }

SimWorld::State SimWorld::saveState() const {
  const Impl& I = *impl_;
  return {std::vector<double>(I.d->qpos, I.d->qpos + I.m->nq), std::vector<double>(I.d->qvel, I.d->qvel + I.m->nv), I.d->time,
          I.asleep, I.still};
}

void SimWorld::restoreState(const State& s) {
  Impl& I = *impl_;
  I.wakeAll();
  std::copy(s.qpos.begin(), s.qpos.end(), I.d->qpos);
  std::copy(s.qvel.begin(), s.qvel.end(), I.d->qvel);
  I.d->time = s.time;
  if (s.asleep.size() == I.asleep.size()) {
    for (size_t i = 0; i < I.asleep.size(); ++i)
      if (s.asleep[i]) I.putToSleep(i);
    I.still = s.still;
  }
  mj_forward(I.m, I.d);
}

int SimWorld::controlsPerStep() const { return impl_->m->nu; }

bool SimWorld::objectAsleep(int i) const { return impl_->asleep.at(static_cast<size_t>(i)) != 0; }

double SimWorld::replayControls(const std::vector<double>& log, ReplayCounts* counts) {
  Impl& I = *impl_;
  const double t0 = I.d->time;
  for (size_t k = 0; k + I.m->nu <= log.size(); k += I.m->nu) {
    std::copy(log.begin() + k, log.begin() + k + I.m->nu, I.d->ctrl);
    I.physicsStep();
    if (counts) {
      ++counts->steps;
      counts->contacts += I.d->ncon;
      counts->rows += I.d->nefc;
      counts->iterations += I.d->solver_iter;
      counts->dof += I.m->nv;
      counts->objects += static_cast<long>(I.asleep.size());
      counts->asleep += std::count(I.asleep.begin(), I.asleep.end(), 1);
    }
  }
  return I.d->time - t0;
}

void SimWorld::updateKinematics() { mj_kinematics(impl_->m, impl_->d); }

void SimWorld::setWeld(int i, bool on) {
  Impl& I = *impl_;
  I.wake(static_cast<size_t>(i));
  const int eq = I.obj_weld[i];
  if (eq < 0) return;
  if (on) {
    // MuJoCo's weld relpose is the pose of body2 (the object) in body1 (the hand).
    mj_kinematics(I.m, I.d);
    const int b1 = I.m->eq_obj1id[eq], b2 = I.m->eq_obj2id[eq];
    const Pose T1 = poseOf(I.d->xpos + 3 * b1, I.d->xmat + 9 * b1);
    const Pose T2 = poseOf(I.d->xpos + 3 * b2, I.d->xmat + 9 * b2);
    const Pose T12 = T1.inverse() * T2;
    const Quat q(T12.linear());
    mjtNum* data = I.m->eq_data + mjNEQDATA * eq;
    data[0] = data[1] = data[2] = 0;
    data[3] = T12.translation().x(), data[4] = T12.translation().y(), data[5] = T12.translation().z();
    data[6] = q.w(), data[7] = q.x(), data[8] = q.y(), data[9] = q.z();
    data[10] = 1;
  }
  I.m->eq_active[eq] = on ? 1 : 0;
}

std::pair<Pose, Vec3> SimWorld::site(const std::string& name) const {
  const Impl& I = *impl_;
  const int id = mj_name2id(I.m, mjOBJ_SITE, name.c_str());
  if (id < 0) throw InputError("scene", "expected a site named '" + name + "'");
  mj_kinematics(I.m, I.d);
  const mjtNum* s = I.m->site_size + 3 * id;
  return {poseOf(I.d->site_xpos + 3 * id, I.d->site_xmat + 9 * id), Vec3(s[0], s[1], s[2])};
}

std::string mujocoVersion() { return std::to_string(mj_version() / 100) + "." + std::to_string(mj_version() / 10 % 10) + "." + std::to_string(mj_version() % 10); }

Pose SimWorld::cameraOffset(int cam) const {
  const auto it = impl_->camera_offsets.find(cam);
  return it == impl_->camera_offsets.end() ? Pose::Identity() : it->second;
}

Pose SimWorld::cameraOffset(const std::string& name) const {
  const int cam = mj_name2id(impl_->m, mjOBJ_CAMERA, name.c_str());
  return cam < 0 ? Pose::Identity() : cameraOffset(cam);
}

bool SimWorld::setCameraOffset(const std::string& name, const Pose& T_mount_camera) {
  const int cam = mj_name2id(impl_->m, mjOBJ_CAMERA, name.c_str());
  if (cam < 0) return false;
  impl_->camera_offsets[cam] = T_mount_camera;
  return true;
}

std::vector<Obstacle> SimWorld::staticObstacles() const {
  const Impl& I = *impl_;
  mj_kinematics(I.m, I.d);
  std::vector<Obstacle> out;
  for (int g = 0; g < I.m->ngeom; ++g) {
    if (!I.static_geom[g] || (I.m->geom_contype[g] == 0 && I.m->geom_conaffinity[g] == 0)) continue;  // drawn only
    Obstacle o;
    const mjtNum* s = I.m->geom_size + 3 * g;
    o.T_world = poseOf(I.d->geom_xpos + 3 * g, I.d->geom_xmat + 9 * g);
    switch (I.m->geom_type[g]) {
      case mjGEOM_BOX: o.type = Obstacle::Type::kBox; o.size = Vec3(s[0], s[1], s[2]); break;
      case mjGEOM_SPHERE: o.type = Obstacle::Type::kSphere; o.size = Vec3(s[0], 0, 0); break;
      case mjGEOM_CYLINDER: o.type = Obstacle::Type::kCylinder; o.size = Vec3(s[0], s[1], 0); break;
      case mjGEOM_CAPSULE: o.type = Obstacle::Type::kCapsule; o.size = Vec3(s[0], s[1], 0); break;
      case mjGEOM_MESH: {
        // A convex mesh piece (a URDF part's, a scene's own) as the box of its vertices in the
        // geom's frame (MuJoCo's: the piece's principal axes): exact for a box-shaped piece, else
        // larger than the piece, never smaller.
        const int mesh = I.m->geom_dataid[g];
        const float* v = I.m->mesh_vert + 3 * I.m->mesh_vertadr[mesh];
        Vec3 lo = Vec3::Constant(INFINITY), hi = -lo;
        for (int k = 0; k < I.m->mesh_vertnum[mesh]; ++k) {
          const Vec3 p(v[3 * k], v[3 * k + 1], v[3 * k + 2]);
          lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
        }
        o.type = Obstacle::Type::kBox;
        o.size = (hi - lo) / 2;
        o.T_world = o.T_world * Eigen::Translation3d((hi + lo) / 2);
        break;
      }
      default: continue;  // planes: not exported
    }
    const char* name = mj_id2name(I.m, mjOBJ_GEOM, g);
    o.name = name ? name : "geom" + std::to_string(g);
    out.push_back(o);
  }
  return out;
}

double SimWorld::externalForce() const { return contactForces().first; }

double SimWorld::handForce() const { return contactForces().second; }

std::pair<double, double> SimWorld::contactForces() const {
  const Impl& I = *impl_;
  std::map<int, Vec3> net;  // force on each group, world frame
  for (int i = 0; i < I.d->ncon; ++i) {
    const mjContact& c = I.d->contact[i];
    const int g1 = I.body_group[I.m->geom_bodyid[c.geom1]], g2 = I.body_group[I.m->geom_bodyid[c.geom2]];
    if ((g1 >= 0) == (g2 >= 0) || c.efc_address < 0) continue;  // robot with robot, or nothing of the robot
    mjtNum f[6];
    mj_contactForce(I.m, I.d, i, f);
    // The contact frame's rows: normal (from geom1 to geom2), then the tangents. The force is
    // geom1's on geom2.
    Vec3 F = Vec3::Zero();
    for (int k = 0; k < 3; ++k) F += f[k] * Vec3(c.frame[3 * k], c.frame[3 * k + 1], c.frame[3 * k + 2]);
    const int g = g1 >= 0 ? g1 : g2;
    const auto it = net.try_emplace(g, Vec3::Zero()).first;  // Eigen's default is uninitialized
    it->second += g1 >= 0 ? Vec3(-F) : F;
  }
  double worst = 0, hand = 0;
  for (const auto& [g, F] : net) {
    const double f = F.norm();
    if (!std::isfinite(f)) continue;  // a diverging state is the instability monitor's to report
    worst = std::max(worst, f);
    if (g == I.hand_body) hand = f;
  }
  return {worst, hand};
}

std::vector<int> SimWorld::objectsTouched() const {
  const Impl& I = *impl_;
  std::vector<int> out;
  for (int i = 0; i < I.d->ncon; ++i) {
    const mjContact& c = I.d->contact[i];
    if (c.dist > 0) continue;
    int o = -1;
    if (I.robot_geom[c.geom1]) o = I.geom_object[c.geom2];
    else if (I.robot_geom[c.geom2]) o = I.geom_object[c.geom1];
    if (o >= 0 && std::find(out.begin(), out.end(), o) == out.end()) out.push_back(o);
  }
  std::sort(out.begin(), out.end());
  return out;
}

int SimWorld::collisionEvents() const { return impl_->collision_events; }
const std::vector<std::string>& SimWorld::collisionLog() const { return impl_->collision_log; }
bool SimWorld::unstable() const { return impl_->unstable; }
const std::string& SimWorld::instabilityReason() const { return impl_->instability; }

}  // namespace mm
