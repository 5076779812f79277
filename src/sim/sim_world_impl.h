// SimWorld's insides, shared by its source files (sim_world.cc: loading, state, queries;
// sim_compile.cc: a scene composed and compiled, physics options; sim_physics.cc: the step, the
// velocity-product term, sleeping, monitors). Internal to src/sim/: it is the one header of ours
// that includes MuJoCo, and no file outside src/sim/ includes it (tests/layering_test.sh).
#pragma once
#include <mujoco/mujoco.h>

#include <map>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "robot/robot_spec.h"
#include "sim/controllers.h"
#include "sim/sim_world.h"

namespace mm {

/// The pose of a MuJoCo frame (position, row-major rotation matrix).
Pose poseOf(const mjtNum* pos, const mjtNum* mat);
/// The last warning MuJoCo raised in this thread ("" after SimWorld::reset).
std::string& lastMujocoWarning();

struct SimWorld::Impl {
  mjModel* m = nullptr;
  mjData* d = nullptr;
  uint64_t serial = 0;  ///< unique in the process: a model freed and another made at its address differ
  int dof = 0;
  std::vector<int> arm_qpos, arm_dof, arm_act;
  std::vector<double> effort;
  int finger_qpos[2] = {0, 0}, finger_dof[2] = {0, 0}, finger_act[2] = {0, 0};
  int tcp_site = -1;
  std::vector<int> obj_body, obj_qpos, obj_dof, obj_geom, obj_weld;  ///< obj_geom: its first colliding geom
  std::vector<std::vector<int>> obj_colliders;  ///< every colliding geom of an object (a mesh object's convex pieces)
  std::vector<Pose> obj_park;
  std::vector<std::shared_ptr<const std::vector<ConvexPiece>>> obj_pieces;  ///< a mesh object's convex pieces, else null
  std::vector<Vec3> obj_half;  ///< a mesh object's bounding box (half sizes) in its frame
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
  // The state at the start of the last control period (stepServo): where MuJoCo flags a bad state
  // it resets its data (the objects parked, time 0), and the world goes back to this instead and
  // stays there (kinematic steps only), so what the trial did before is still what it scores.
  struct GoodState {
    std::vector<mjtNum> qpos, qvel, act, ctrl, mocap_pos, mocap_quat, xfrc_applied, qacc_warmstart;
    mjtNum time = 0;
  } good;
  void saveGood();
  void restoreGood();
  std::map<int, Pose> camera_offsets;  ///< a knocked camera's pose from its mount (setCameraOffset), by camera id
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
  /// answers it: the object creeps along the pads (1.6 mm through a full-speed transfer,
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
  void addVelocityProduct();

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

  void initSleep();
  void wake(size_t i);
  void wakeAll();
  bool moverNear(size_t i) const;
  void updateSleep();
  void putToSleep(size_t i);

  /// One physics step: mj_step as MuJoCo's split step, the velocity-product term in between.
  void physicsStep();

  /// The step's bad-state warnings and the robot's collision events with the static scene.
  void monitor();
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

}  // namespace mm
