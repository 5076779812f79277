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

namespace mm {
namespace {

thread_local std::string g_last_warning;

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
void onMujocoWarning(const char* msg) { g_last_warning = msg; }

}  // namespace

void installMujocoHandlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    mju_user_error = onMujocoError;
    mju_user_warning = onMujocoWarning;
  });
  installMidphase();
}

namespace {

Pose poseOf(const mjtNum* pos, const mjtNum* mat) {
  Pose T = Pose::Identity();
  for (int r = 0; r < 3; ++r) {
    T.translation()[r] = pos[r];
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = mat[3 * r + c];
  }
  return T;
}

}  // namespace

struct SimWorld::Impl {
  mjModel* m = nullptr;
  mjData* d = nullptr;
  uint64_t serial = 0;  ///< unique in the process: a model freed and another made at its address differ
  int dof = 0;
  std::vector<int> arm_qpos, arm_dof, arm_act;
  std::vector<double> effort;
  int finger_qpos[2] = {0, 0}, finger_dof[2] = {0, 0}, finger_act[2] = {0, 0};
  int tcp_site = -1;
  std::vector<int> obj_body, obj_qpos, obj_dof, obj_geom, obj_weld;
  std::vector<Pose> obj_park;
  std::vector<int> obstacle_body, obstacle_mocap, obstacle_geom;
  std::vector<char> obstacle_placed;
  std::vector<char> robot_geom, static_geom, foreign_geom;
  std::vector<int> geom_object;  ///< the object index of an object's geom, else -1
  std::vector<unsigned char> geom_label;  ///< SegmentLabel
  std::vector<int> body_group;   ///< a robot body's force group: the hand for the hand and what it carries, else itself; -1 off the robot
  int hand_body = -1;
  int robot_root = -1;
  ServoGains gains;
  bool stiff = false;
  double payload_mass = 0;
  Vec3 payload_tcp = Vec3::Zero();
  double finger_ramp[2] = {0, 0};
  double finger_goal = -1;  ///< the opening last commanded [m per finger]
  double finger_vmax = 0.2;
  // monitors
  std::set<std::pair<int, int>> touching;
  int collision_events = 0;
  double last_contact_time = -1e9;
  std::vector<std::string> collision_log;
  bool unstable = false;
  std::string instability;
  // scratch
  std::vector<mjtNum> scratch_a, scratch_b, scratch_jac;
  std::vector<double>* ctrl_log = nullptr;
  int substeps = 1;  ///< physics steps per control period
  bool velocity_product = true;  ///< PhysicsOptions::velocity_product
  bool midphase = true;          ///< PhysicsOptions::midphase
  bool sleep = true;             ///< PhysicsOptions::sleep
  std::vector<char> asleep;      ///< per object
  std::vector<int> still;        ///< per object: consecutive steps at rest
  std::vector<char> moving;      ///< per object, this step: awake and faster than the rest thresholds
  std::vector<char> supported;   ///< per object, this step: resting on the static world only
  std::vector<int> saved_contype, saved_conaffinity;  ///< per object: its geom's, while asleep
  std::vector<int> mover_geoms;  ///< the robot's geoms and the obstacles' (always movers)
  std::vector<mjtNum> cacc_vp;   ///< per body, the com-based acceleration at qacc = 0 (6 x nbody)
  std::vector<char> vp_needed;   ///< per body: in a contact, or an ancestor of one that is
  mjOption scene_option;  ///< the scene's own numerics, before any PhysicsOptions

  ~Impl() {
    if (d) mj_deleteData(d);
    if (m) mj_deleteModel(m);
  }

  /// MuJoCo asks each contact row for J qacc = aref (aref = -b v - k r, v the row's velocity
  /// J qvel), but a row's velocity changes by J qacc + J'q': the velocity-product term, which
  /// MuJoCo's constraint dynamics leave out (its documentation, "Computation"). For an object held
  /// by friction on a swinging arm, J'q' is the difference of the hand's and the object's
  /// centripetal and Coriolis accelerations at the contact, and nothing but the damping -b v
  /// answers it: the object creeps along the pads (issue 13: 1.6 mm through a full-speed transfer,
  /// always the same way). Subtracting all of J'q' overshoots in MuJoCo's discrete step, measured:
  /// the creep reverses. The step moves the contact points along curved paths (the hand's point by
  /// exp of its joints' motion, the object's by its free joint's rotation), which part way makes up
  /// for the missing term. For a sticking row with a soft constraint of impedance d (it reaches
  /// d of aref) and damping b, its velocity u at a step's start and the relative displacement over
  /// a step with timestep h obey, with k = d b h and c the part of J'q' subtracted,
  ///   u' = (1 - k) u + h (1 - d c) J'q',   displacement = h ((1 - k) u - h d c J'q') + h^2/2 J'q',
  /// and the steady displacement vanishes for d c = 1 - k/2: half of J'q' when the constraint is
  /// deadbeat (k = 1, the pads' solref of two timesteps), all of it as h -> 0. So each row's aref
  /// loses (1 - k/2) / d of its J'q', computed between mj_step1 (aref, cvel, cdof_dot, impedances)
  /// and mj_step2 (the solve).
  void addVelocityProduct() {
    if (!velocity_product || d->ncon == 0) return;
    const int nb = m->nbody;
    cacc_vp.assign(6 * static_cast<size_t>(nb), 0.0);
    vp_needed.assign(static_cast<size_t>(nb), 0);  // the bodies in a contact and their ancestors
    for (int i = 0; i < d->ncon; ++i) {
      const mjContact& c = d->contact[i];
      if (c.exclude || c.efc_address < 0) continue;
      for (int b : {m->geom_bodyid[c.geom1], m->geom_bodyid[c.geom2]})
        for (; b > 0 && !vp_needed[static_cast<size_t>(b)]; b = m->body_parentid[b]) vp_needed[static_cast<size_t>(b)] = 1;
    }
    for (int b = 1; b < nb; ++b) {  // as mj_rne with qacc = 0 and no gravity: parents come first
      if (!vp_needed[static_cast<size_t>(b)]) continue;
      mjtNum* a = cacc_vp.data() + 6 * b;
      const mjtNum* ap = cacc_vp.data() + 6 * m->body_parentid[b];
      for (int k = 0; k < 6; ++k) a[k] = ap[k];
      for (int j = m->body_dofadr[b]; j < m->body_dofadr[b] + m->body_dofnum[b]; ++j)
        for (int k = 0; k < 6; ++k) a[k] += d->cdof_dot[6 * j + k] * d->qvel[j];
    }
    // A point's acceleration in the world frame (angular, linear), as mj_objectAcceleration turns
    // the com-based spatial acceleration into a point's: shift to the point, add omega x v.
    auto pointAcc = [&](int b, const mjtNum* p, mjtNum out[6]) {
      if (b == 0) {
        mju_zero(out, 6);
        return;
      }
      const mjtNum* com = d->subtree_com + 3 * m->body_rootid[b];
      mjtNum vel[6], corr[3];
      mju_transformSpatial(out, cacc_vp.data() + 6 * b, 0, p, com, nullptr);
      mju_transformSpatial(vel, d->cvel + 6 * b, 0, p, com, nullptr);
      mju_cross(corr, vel, vel + 3);
      mju_addTo3(out + 3, corr);
    };
    const bool elliptic = m->opt.cone == mjCONE_ELLIPTIC;
    const double h = m->opt.timestep;
    for (int i = 0; i < d->ncon; ++i) {
      const mjContact& c = d->contact[i];
      if (c.exclude || c.efc_address < 0) continue;
      mjtNum a1[6], a2[6], rel[6];
      pointAcc(m->geom_bodyid[c.geom1], c.pos, a1);
      pointAcc(m->geom_bodyid[c.geom2], c.pos, a2);
      mju_sub(rel, a2, a1, 6);  // MuJoCo's contact rows are body 2's motion relative to body 1's
      // In the contact frame: normal, tangent 1, tangent 2 (linear), then torsion and rolling.
      const mjtNum comp[6] = {mju_dot3(c.frame, rel + 3),     mju_dot3(c.frame + 3, rel + 3),
                              mju_dot3(c.frame + 6, rel + 3), mju_dot3(c.frame, rel),
                              mju_dot3(c.frame + 3, rel),     mju_dot3(c.frame + 6, rel)};
      auto subtract = [&](int row, mjtNum jdot) {
        const mjtNum* kbip = d->efc_KBIP + 4 * row;
        const mjtNum imp = std::max(kbip[2], mjMINIMP);
        d->efc_aref[row] -= (1.0 / imp - 0.5 * kbip[1] * h) * jdot;
      };
      const int adr = c.efc_address;
      if (elliptic || c.dim == 1) {
        for (int r = 0; r < c.dim; ++r) subtract(adr + r, comp[r]);
      } else {  // pyramidal: edge rows J_normal +- friction_k J_k
        for (int k = 0; k < c.dim - 1; ++k) {
          subtract(adr + 2 * k, comp[0] + c.friction[k] * comp[k + 1]);
          subtract(adr + 2 * k + 1, comp[0] - c.friction[k] * comp[k + 1]);
        }
      }
    }
  }

  // ---- sleeping ----
  // An object sleeps after kSleepSteps steps slower than 0.5 mm/s and 5 mrad/s, resting on the
  // static world alone, with nothing moving within 2 cm of it (a lower bound on the distance between
  // the shapes, sim/midphase.h): its geom leaves collision (contype, conaffinity 0), its
  // weight is held by an applied force and its velocity kept at zero, so the model solves none of
  // its contacts. It wakes, everything restored, as soon as something moving comes that near:
  // the robot, an obstacle, or an object moving faster than those thresholds. Objects at rest
  // together fall asleep together; waking spreads through the same test.
  static constexpr int kSleepSteps = 50;  // 0.1 s at 2 ms
  static constexpr double kSleepGap = 0.02;  // [m]

  void initSleep() {
    const size_t n = obj_body.size();
    asleep.assign(n, 0);
    still.assign(n, 0);
    saved_contype.assign(n, 0);
    saved_conaffinity.assign(n, 0);
    mover_geoms.clear();
    for (int g = 0; g < m->ngeom; ++g)
      if (robot_geom[g] || foreign_geom[g]) mover_geoms.push_back(g);
  }
  void wake(size_t i) {
    if (i >= asleep.size() || !asleep[i]) return;
    const int g = obj_geom[i], b = obj_body[i];
    m->geom_contype[g] = saved_contype[i];
    m->geom_conaffinity[g] = saved_conaffinity[i];
    std::fill(d->xfrc_applied + 6 * b, d->xfrc_applied + 6 * b + 6, 0.0);
    asleep[i] = 0;
    still[i] = 0;
  }
  void wakeAll() {
    for (size_t i = 0; i < asleep.size(); ++i) wake(i);
    std::fill(still.begin(), still.end(), 0);
  }
  bool moverNear(size_t i) const {
    const int g = obj_geom[i];
    const mjtNum* p = d->geom_xpos + 3 * g;
    auto near = [&](int h) {  // bounding spheres first (cheap), then the shapes' gap bound
      const mjtNum* q = d->geom_xpos + 3 * h;
      const mjtNum dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
      const mjtNum r = m->geom_rbound[g] + m->geom_rbound[h] + kSleepGap;
      return dx * dx + dy * dy + dz * dz < r * r && geomGapLowerBound(m, d, g, h) < kSleepGap;
    };
    for (int h : mover_geoms)
      if (m->geom_type[h] != mjGEOM_PLANE && near(h)) return true;
    for (size_t j = 0; j < obj_geom.size(); ++j)
      if (j != i && moving[j] && near(obj_geom[j])) return true;
    return false;
  }
  void updateSleep() {
    if (!sleep) return;
    const size_t n = obj_body.size();
    moving.assign(n, 0);
    for (size_t i = 0; i < n; ++i) {
      const mjtNum* v = d->qvel + obj_dof[i];
      moving[i] = !asleep[i] && (v[0] * v[0] + v[1] * v[1] + v[2] * v[2] >= 0.5e-3 * 0.5e-3 ||
                                 v[3] * v[3] + v[4] * v[4] + v[5] * v[5] >= 5e-3 * 5e-3);
    }
    // Waking spreads at once: an object just woken counts as moving for its sleeping neighbours
    // (one resting against it may be pushed next).
    for (bool woke = true; woke;) {
      woke = false;
      for (size_t i = 0; i < n; ++i)
        if (asleep[i] && moverNear(i)) wake(i), moving[i] = 1, woke = true;
    }
    // Only an object resting on the static world sleeps: every contact with a static geom, its
    // normal within 25 degrees of vertical. One leaning on another object or against a wall is
    // held by friction, and MuJoCo's soft contacts let it creep on: freezing it there changed
    // dense bins (measured: 477 of 500 cubes placed against 490).
    supported.assign(n, 1);
    for (int c = 0; c < d->ncon; ++c) {
      const mjContact& con = d->contact[c];
      for (int side = 0; side < 2; ++side) {
        const int g = side ? con.geom2 : con.geom1, other = side ? con.geom1 : con.geom2;
        const int i = geom_object[g];
        if (i < 0) continue;
        const int b = m->geom_bodyid[other];
        const bool on_static = m->body_weldid[b] == 0 && m->body_mocapid[b] < 0;
        if (!on_static || std::abs(con.frame[2]) < 0.906) supported[static_cast<size_t>(i)] = 0;
      }
    }
    for (size_t i = 0; i < n; ++i) {
      if (asleep[i]) std::fill(d->qvel + obj_dof[i], d->qvel + obj_dof[i] + 6, 0.0);
      else still[i] = !moving[i] && supported[i] && !moverNear(i) ? still[i] + 1 : 0;
    }
    for (size_t i = 0; i < n; ++i)
      if (!asleep[i] && still[i] >= kSleepSteps) putToSleep(i);
  }
  void putToSleep(size_t i) {
    const int g = obj_geom[i], b = obj_body[i];
    saved_contype[i] = m->geom_contype[g];
    saved_conaffinity[i] = m->geom_conaffinity[g];
    m->geom_contype[g] = m->geom_conaffinity[g] = 0;
    std::fill(d->qvel + obj_dof[i], d->qvel + obj_dof[i] + 6, 0.0);
    for (int k = 0; k < 3; ++k) d->xfrc_applied[6 * b + k] = -m->body_mass[b] * m->opt.gravity[k];
    asleep[i] = 1;
  }

  /// One physics step: mj_step as MuJoCo's split step, the velocity-product term in between.
  void physicsStep() {
    setMidphase(midphase);
    updateSleep();
    mj_step1(m, d);
    addVelocityProduct();
    mj_step2(m, d);
  }

  void monitor() {
    static const int kBad[] = {mjWARN_BADQPOS, mjWARN_BADQVEL, mjWARN_BADQACC, mjWARN_BADCTRL,
                               mjWARN_CONTACTFULL, mjWARN_CNSTRFULL};
    static const char* kNames[] = {"bad qpos", "bad qvel", "bad qacc", "bad ctrl", "contact buffer full",
                                   "constraint buffer full"};
    for (int k = 0; k < 6; ++k) {
      if (d->warning[kBad[k]].number > 0 && !unstable) {
        unstable = true;
        std::ostringstream s;
        s << "MuJoCo warning '" << kNames[k] << "' at t=" << d->time << " s";
        if (!g_last_warning.empty()) s << ": " << g_last_warning;
        instability = s.str();
      }
    }
    // A collision event is an episode of penetrating contact between the robot and the static
    // scene or an obstacle: its onset counts once, however many geoms touch, and bounces within 0.1 s of the
    // last contact belong to the same event.
    std::set<std::pair<int, int>> now;
    for (int i = 0; i < d->ncon; ++i) {
      const mjContact& c = d->contact[i];
      if (c.dist > -1e-4) continue;  // touching within 0.1 mm is not a collision
      int r = -1, s = -1;
      const bool hard1 = static_geom[c.geom1] || foreign_geom[c.geom1], hard2 = static_geom[c.geom2] || foreign_geom[c.geom2];
      if (robot_geom[c.geom1] && hard2) r = c.geom1, s = c.geom2;
      else if (robot_geom[c.geom2] && hard1) r = c.geom2, s = c.geom1;
      if (r < 0) continue;
      now.insert({r, s});
    }
    if (!now.empty()) {
      if (d->time - last_contact_time > 0.1) {
        ++collision_events;
        std::ostringstream o;
        o << mj_id2name(m, mjOBJ_GEOM, now.begin()->first) << " hit " << mj_id2name(m, mjOBJ_GEOM, now.begin()->second)
          << " at t=" << d->time;
        if (collision_log.size() < 20) collision_log.push_back(o.str());
      }
      last_contact_time = d->time;
    }
    touching.swap(now);
  }
};

struct SimWorld::Shared {
  std::string scene_xml;
  RobotSpec spec;
  std::vector<std::string> joint_names;
  VecX home;
  std::map<std::string, std::unique_ptr<Impl>> models;  // by object list
  std::vector<double>* ctrl_log = nullptr;
  PhysicsOptions physics;
  std::string physics_file;  // where the physics options came from, for errors
};

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
  }
  return key;
}

}  // namespace

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
  if (!I.m) throw InputError(scene_xml, std::string("MuJoCo rejected the scene with ") + S.spec.name + " mounted: " + err);
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
    if (m->body_jntnum[b] != 1 || m->jnt_type[m->body_jntadr[b]] != mjJNT_FREE || m->body_geomnum[b] != 1 ||
        (m->geom_type[m->body_geomadr[b]] != mjGEOM_BOX && m->geom_type[m->body_geomadr[b]] != mjGEOM_CYLINDER))
      throw InputError(scene_xml, "object body '" + name + "' must have one free joint and one box or cylinder geom");
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
    const int g = I.obj_geom[k];
    const double hz = m->geom_size[3 * g + (m->geom_type[g] == mjGEOM_CYLINDER ? 1 : 2)];
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
  for (size_t i = 0; i < I.obj_geom.size(); ++i) I.geom_object[I.obj_geom[i]] = static_cast<int>(i);
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
  g_last_warning.clear();
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

ObjectState SimWorld::object(int i) const {
  const Impl& I = *impl_;
  ObjectState o;
  o.index = i;
  o.name = mj_id2name(I.m, mjOBJ_BODY, I.obj_body[i]);
  const mjtNum* q = I.d->qpos + I.obj_qpos[i];
  o.T_world_object = makePose(Vec3(q[0], q[1], q[2]), Quat(q[3], q[4], q[5], q[6]));
  const mjtNum* s = I.m->geom_size + 3 * I.obj_geom[i];
  if (I.m->geom_type[I.obj_geom[i]] == mjGEOM_CYLINDER) {
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
    if (con.geom1 == I.obj_geom[i] || con.geom2 == I.obj_geom[i]) worst = std::max(worst, -con.dist);
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
      return;
    }
    I.monitor();  // contacts found by this step's collision pass (state at the step's start)
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

std::vector<Obstacle> SimWorld::staticObstacles() const {
  const Impl& I = *impl_;
  mj_kinematics(I.m, I.d);
  std::vector<Obstacle> out;
  for (int g = 0; g < I.m->ngeom; ++g) {
    if (!I.static_geom[g]) continue;
    Obstacle o;
    const mjtNum* s = I.m->geom_size + 3 * g;
    switch (I.m->geom_type[g]) {
      case mjGEOM_BOX: o.type = Obstacle::Type::kBox; o.size = Vec3(s[0], s[1], s[2]); break;
      case mjGEOM_SPHERE: o.type = Obstacle::Type::kSphere; o.size = Vec3(s[0], 0, 0); break;
      case mjGEOM_CYLINDER: o.type = Obstacle::Type::kCylinder; o.size = Vec3(s[0], s[1], 0); break;
      case mjGEOM_CAPSULE: o.type = Obstacle::Type::kCapsule; o.size = Vec3(s[0], s[1], 0); break;
      default: continue;  // planes, meshes: not exported
    }
    o.T_world = poseOf(I.d->geom_xpos + 3 * g, I.d->geom_xmat + 9 * g);
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
