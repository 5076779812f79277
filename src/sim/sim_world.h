// SimWorld: one MuJoCo model + data for one worker (the model is the robot mounted in a scene).
// Steps the physics with a joint servo and finger force control, or updates it kinematically for
// the mock hardware. Watches contacts (robot vs table and bins) and MuJoCo's instability warnings.
// MuJoCo stays inside sim_world.cc.
#pragma once
#include <memory>
#include <utility>
#include <string>
#include <vector>

#include "core/config.h"
#include "core/geometry.h"
#include "robot/robot_model.h"
#include "robot/solid_mesh.h"
#include "sim/object_catalogue.h"

struct mjModel_;  // MuJoCo's model and data, named only for the renderer (render/)
struct mjData_;

namespace mm {

/// A geom's label in a segmentation image.
enum SegmentLabel : unsigned char {
  kSegmentScene = 0,     ///< the static scene: floor, table, bins, tray
  kSegmentRobot = 1,     ///< the arm and its gripper
  kSegmentObject0 = 2,   ///< object k is kSegmentObject0 + k (at most 252 objects)
  kSegmentObstacle = 255,
};

struct ServoGains {
  double kp = 400.0;   ///< [1/s^2] joint position gain of the computed-torque servo
  double kd = 40.0;    ///< [1/s] joint velocity gain
  // Contact tasks (a push): ten times the stiffness, critically damped. A computed-torque servo's
  // stiffness against an external force is M kp, small at the wrist: at kp = 400/s^2 the ~1 N of a
  // pushed cube's friction moves the wrist by 0.05 rad, the protective stop's limit. A real arm is
  // switched to a high joint impedance for such a task (as Franka's setJointImpedance).
  double stiff_kp = 4000.0;  ///< [1/s^2]
  double stiff_kd = 126.0;   ///< [1/s]
  // The finger PD runs explicitly at the 2 ms step on ~0.025 kg (finger + armature): stable needs
  // kd dt / m < 2 and kp dt^2 / m well under 1 (here 0.64 and 0.32); higher gains limit-cycle.
  double finger_kp = 2000.0;  ///< [N/m]
  double finger_kd = 8.0;     ///< [N s/m]
};

/// The simulator's numerics, each overriding the scene's <option> when set (section "physics").
/// The servo's control period stays 2 ms (500 Hz) whatever the timestep: a shorter timestep is
/// substepped with the control held (a digital controller's zero-order hold).
struct PhysicsOptions {
  void declare(ConfigArchive& a);
  double timestep = 0;             ///< [s] 0: the scene's; else it must divide the control period
  std::string integrator = "scene";  ///< scene | Euler | implicit (not RK4: the split step runs it as Euler)
  std::string cone = "scene";        ///< scene | pyramidal | elliptic
  std::string jacobian = "scene";    ///< scene | dense | sparse | auto
  std::string solver = "scene";      ///< scene | PGS | CG | Newton
  int iterations = 0;                ///< 0: the scene's
  double tolerance = -1;             ///< < 0: the scene's
  int noslip_iterations = -1;        ///< < 0: the scene's
  /// Adds to every contact's reference acceleration the velocity-product term J'q' that MuJoCo 2.2's
  /// constraints leave out, so that static friction holds an object on a swinging arm.
  bool velocity_product = true;
  /// Skips narrow-phase tests a cheap bound proves empty (sim/midphase.h): the same contacts.
  bool midphase = true;
  /// Objects at rest on the static world, away from anything moving, sleep (held still, out of
  /// collision) until something moving comes near (as physics engines put resting bodies to sleep).
  bool sleep = true;
  /// Today's scene as the issue measured it: the scene's numerics with none of the additions
  /// above (the bench's baseline).
  static PhysicsOptions sceneAsIs() {
    PhysicsOptions p;
    p.velocity_product = p.midphase = p.sleep = false;
    return p;
  }
};

/// [s] The servo's control period (500 Hz), whatever the physics timestep.
constexpr double kControlPeriod = 0.002;

/// MuJoCo's version, e.g. "2.2.2".
std::string mujocoVersion();
/// Installs our MuJoCo error and warning handlers (once per process; MuJoCo's defaults wait on
/// stdin and write MUJOCO_LOG.TXT).
void installMujocoHandlers();

class SimWorld {
 public:
  /// Checks a scene MJCF, mounts the robot (arm and gripper) in it, adds `objects`
  /// (sim/scene_compose.h) and loads the result. Throws InputError for bad files.
  static std::unique_ptr<SimWorld> load(const std::string& scene_xml, const RobotModel& robot,
                                        const std::vector<ObjectKind>& objects = {});
  /// Makes the model hold exactly `objects` (object_0 is objects[0], ...): the scene recomposed and
  /// compiled on the first use of a list, kept for the next (a worker meets a few lists). The
  /// state is then the model's initial one: call reset().
  void setObjects(const std::vector<ObjectKind>& objects);
  /// The models compiled so far (one per distinct object list).
  int modelsCompiled() const;
  ~SimWorld();
  SimWorld(const SimWorld&) = delete;
  SimWorld& operator=(const SimWorld&) = delete;

  /// Back to the model's initial state, arm at q (dim dof), fingers open, monitors cleared.
  void reset(const VecX& q_arm);
  double time() const;        ///< simulated time [s]
  double timestep() const;    ///< [s] the physics timestep
  double controlPeriod() const;  ///< [s] one stepServo / stepKinematic: kControlPeriod
  /// Applies `physics` to every model, now and compiled later. Throws InputError (naming `file`)
  /// for a timestep that does not divide the control period.
  void setPhysics(const PhysicsOptions& physics, const std::string& file);

  // Arm and fingers.
  VecX armPositions() const;
  VecX armVelocities() const;
  void setArm(const VecX& q);      ///< kinematic: position set, velocity zeroed
  double fingerOpening() const;    ///< mean of the two fingers [m]
  double fingerForce() const;      ///< closing force of the finger actuators, mean of the two [N] (>= 0)
  void setFingers(double opening); ///< kinematic
  Pose tcpPose() const;            ///< T_world_tcp

  // Objects: those setObjects() put in the model; reset() parks them all at the scene's object_park.
  int numObjects() const;
  ObjectState object(int i) const;
  /// Object i's surface as the renderer draws it (its geoms of groups 0-2: a mesh object's visual
  /// mesh, a box's or cylinder's own shape, tessellated), in the object's frame (object(i)'s
  /// T_world_object), triangles wound counter-clockwise seen from outside [m].
  TriangleMesh objectSurface(int i) const;
  /// Object i's pose as last drawn: its body's pose from the last kinematics (the renderer draws
  /// from it), where object(i) reads the state after the step's integration.
  Pose objectDrawnPose(int i) const;
  Vec3 objectVelocity(int i) const;     ///< linear [m/s]
  void setObjectPose(int i, const Pose& T_world_object);  ///< zero velocity
  void parkObject(int i);
  /// Deepest penetration [m, >= 0] between object i and anything else.
  double objectPenetration(int i) const;

  // Obstacles: mocap bodies named obstacle_<k>, one box geom each, parked off the table until
  // placed (the obstacle_added fault). The robot touching one is a collision event.
  int numObstacles() const;
  Vec3 obstacleHalfSize(int k) const;             ///< [m]
  void placeObstacle(int k, const Pose& T_world_box);  ///< its box's frame; parked again by reset()
  /// The obstacles placed since the last reset, as boxes in the world frame.
  std::vector<Obstacle> placedObstacles() const;

  /// Height [m] of the first surface below point p, ignoring object `exclude` (-1: none).
  double surfaceBelow(const Vec3& p, int exclude) const;

  /// Advances one control period with the arm servoed to (q, qd, qdd) by computed torque (inverse
  /// dynamics feed-forward + PD, clamped to the effort limits) and each finger force-controlled
  /// toward `finger_target` [m] with at most `finger_force` [N]; the torques are computed at the
  /// period's start and held through its physics substeps.
  void stepServo(const VecX& q, const VecX& qd, const VecX& qdd, double finger_target, double finger_force);
  /// Advances one control period without dynamics: positions as set, contacts recomputed (mock hardware).
  void stepKinematic();
  /// Recomputes body and site poses for the positions as set (time does not advance).
  void updateKinematics();

  /// Weld object i to the hand in its current relative pose (weld-on-grasp), or release it.
  void setWeld(int i, bool on);

  /// Moves the mocap body `name` (a calibration board, say) to T_world_body; throws InputError if
  /// the model has no such mocap body.
  void setMocapPose(const std::string& name, const Pose& T_world_body);

  /// A named site's frame and size (box sites: half sizes) [m]; throws InputError if absent.
  std::pair<Pose, Vec3> site(const std::string& name) const;

  // Benchmarking: record every control vector applied by stepServo, and replay a recording with
  // bare mj_step from a saved state (no servo, no monitors) to measure pure simulation cost.
  void recordControls(std::vector<double>* log);
  struct State {
    std::vector<double> qpos, qvel;
    double time = 0;
    std::vector<char> asleep;  ///< per object (PhysicsOptions::sleep)
    std::vector<int> still;    ///< per object: steps at rest so far
  };
  State saveState() const;
  void restoreState(const State& s);
  /// What a replay met, summed over its steps.
  struct ReplayCounts {
    long steps = 0, contacts = 0, rows = 0, iterations = 0;  ///< contacts, constraint rows, solver iterations
    long dof = 0;  ///< the models' degrees of freedom, summed over the steps
    long objects = 0, asleep = 0;  ///< objects in the model, and of them asleep, summed over the steps
  };
  /// Steps once per recorded control vector (one per physics step); returns the simulated seconds
  /// covered, and adds to `counts` when given.
  double replayControls(const std::vector<double>& log, ReplayCounts* counts = nullptr);
  /// Object i is asleep (PhysicsOptions::sleep): at rest, out of collision, until something moves near.
  bool objectAsleep(int i) const;
  /// Controls per step in a recorded log (the model's actuators: arm joints and fingers).
  int controlsPerStep() const;

  /// Static obstacles as the planner should know them: the colliding geoms welded to the world
  /// (table, bins, tray; planes out of reach left out), a mesh geom as the box of its vertices in its
  /// frame (a convex piece of a URDF part: exact for a box, else larger, never smaller).
  std::vector<Obstacle> staticObstacles() const;

  /// [N] The largest net contact force on one part of the robot from outside it, each arm body on
  /// its own and the hand with its fingers and what they hold as one (so a grip's squeeze cancels
  /// and a held object's weight counts, as a wrist force sensor sees them): what a protective stop
  /// on contact force watches. From the last step's constraint forces.
  double externalForce() const;
  /// [N] The hand group's alone (what a guarded move's touch-down watches).
  double handForce() const;
  /// Both: {the largest, the hand's}.
  std::pair<double, double> contactForces() const;
  /// The objects (indices) a robot geom touches now.
  std::vector<int> objectsTouched() const;
  /// Episodes of robot vs table/bin/tray penetration (bounces within 0.1 s are one episode).
  int collisionEvents() const;
  const std::vector<std::string>& collisionLog() const;
  bool unstable() const;                       ///< MuJoCo flagged a bad state
  const std::string& instabilityReason() const;

  const ServoGains& gains() const;
  /// The stiff gains (ServoGains::stiff_kp/kd) on or off; off after reset().
  void setStiff(bool on);
  /// The payload the servo compensates (gravity and the commanded acceleration of `mass` [kg] at
  /// `com_tcp` in the TCP frame); 0: none. Cleared by reset().
  void setPayload(double mass, const Vec3& com_tcp);

  // For the renderer (render/) only: the current model and its data as they are now (the renderer
  // reads them), and each geom's SegmentLabel.
  const mjModel_* mujocoModel() const;
  /// The camera of id `cam` knocked off its mount (a fault's doing): the renderer draws from
  /// T_mount * T_mount_camera (OpenCV's camera frame), while a capture still reports the mount's pose
  /// (what the cell's description says). Identity when it sits on its mount; cleared by reset().
  Pose cameraOffset(int cam) const;
  Pose cameraOffset(const std::string& name) const;  ///< the same by name (identity for no such camera)
  /// False when the scene has no camera `name`.
  bool setCameraOffset(const std::string& name, const Pose& T_mount_camera);
  mjData_* mujocoData() const;
  /// The current model's number, unique in the process (caches key on it, not on the pointer).
  uint64_t modelSerial() const;
  const std::vector<unsigned char>& geomLabels() const;

 private:
  SimWorld();
  struct Impl;    // one compiled model and its data
  struct Shared;  // what every model is composed from, and the compiled models
  static std::unique_ptr<Impl> compile(const Shared& shared, const std::vector<ObjectKind>& objects);
  static void applyPhysics(Impl& model, const PhysicsOptions& physics, const std::string& file);
  std::unique_ptr<Shared> shared_;
  Impl* impl_ = nullptr;  // the current model, owned by shared_
};

}  // namespace mm
