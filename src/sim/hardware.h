// The hardware interface the task code talks to, like ros2_control's read()/write() with a
// position command interface: `mujoco` simulates the arm, `mock` follows commands exactly (like
// mock_components/GenericSystem) and moves objects only when grasped. Task code is identical for
// both; a real-robot backend would implement the same interface.
#pragma once
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/geometry.h"
#include "robot/robot_model.h"

namespace mm {

class SimWorld;

/// Reads camera `name` at width x height as the world is now (the campaign wires a renderer and
/// the sensor's noise in); false with `why` said when it cannot.
using CameraSource = std::function<bool(const std::string& name, int width, int height, Frame& frame, std::string* why)>;

class Hardware {
 public:
  virtual ~Hardware() = default;
  virtual const char* name() const = 0;
  virtual double time() const = 0;    ///< [s] simulated time
  virtual double period() const = 0;  ///< [s] control period (500 Hz)

  virtual VecX jointPositions() const = 0;   ///< [rad] dim dof
  virtual VecX jointVelocities() const = 0;  ///< [rad/s]
  virtual double gripperOpening() const = 0; ///< [m] per finger
  virtual double gripperForce() const = 0;   ///< [N] per finger, closing (what the motors exert)
  /// One control period's joint setpoint: position [rad] with velocity and acceleration feed-forward.
  virtual void write(const VecX& q, const VecX& qd, const VecX& qdd) = 0;
  /// The position last written [rad] (dim dof): where an idle arm is held.
  virtual VecX commandedPositions() const = 0;
  /// Gripper goal: opening per finger [m] and the force limit [N].
  virtual void writeGripper(double opening, double max_force) = 0;
  /// Advances one control period.
  virtual void step() = 0;

  /// Weld-on-grasp (the source's attach plugin): fix object i to the hand, or release it.
  virtual void attach(int i, bool on) = 0;
  /// A high joint impedance for a contact task (a push) on or off.
  virtual void setStiff(bool on) = 0;
  /// The payload the servo compensates, as Franka's setLoad: `mass` [kg] with its centre at
  /// `com_tcp` in the TCP frame; mass 0 clears it.
  virtual void setPayload(double mass, const Vec3& com_tcp) = 0;

  /// A camera of the cell: its depth image (and intrinsics) now. frame.camera.T_world_camera is
  /// where the simulator has it; perception replaces it with calibrated extrinsics when it has
  /// them. False with `why` when the backend has no camera.
  virtual bool capture(const std::string& name, int width, int height, Frame& frame, std::string* why) = 0;
  /// Where capture() gets its images (the backends have none of their own).
  virtual void setCameraSource(CameraSource source) = 0;

  /// The simulator's truth: what a real cell's robot does not know. The ground-truth perception
  /// mode perceives through it; scoring (the evaluation, metrics) and the simulated world's own
  /// doings (a weld's attachment, a fault injected) read it. In camera mode it is guarded
  /// (guardTruth): a read outside a TruthScope is a bug of ours, std::logic_error, so that nothing
  /// the robot decides can rest on it.
  virtual std::vector<ObjectState> objects() const = 0;
  virtual ObjectState object(int i) const = 0;
  virtual Vec3 objectVelocity(int i) const = 0;
  virtual Pose tcpPose() const = 0;
  /// Obstacles that are not part of the cell (placed on the table since the trial began), as an
  /// obstacle sensor sees them: what the robot learns by perceiving.
  virtual std::vector<Obstacle> obstacles() const = 0;
  /// [N] the largest external contact force on one part of the arm or on the hand (a wrist
  /// sensor's view: the held object's weight counts, the grip's squeeze cancels); 0 where the
  /// backend has no forces (mock).
  virtual double externalForce() const = 0;
  /// [N] the same on the hand with its fingers and what they hold only (0 on mock).
  virtual double handForce() const = 0;
  /// The objects the robot touches now (ground truth: for metrics, never for decisions).
  virtual std::vector<int> objectsTouched() const = 0;
  virtual int collisionEvents() const = 0;
  virtual const std::vector<std::string>& collisionLog() const = 0;
  virtual bool unstable() const = 0;
  virtual const std::string& instabilityReason() const = 0;

  /// Guards the truth (objects(), object(), objectVelocity(), tcpPose(), obstacles(),
  /// objectsTouched()) or lifts the guard.
  virtual void guardTruth(bool on) = 0;
  /// TruthScope's: reads are allowed while at least one scope is open.
  virtual void openTruth() const = 0;
  virtual void closeTruth() const = 0;
};

/// A reason to read the simulator's truth in camera mode, for as long as it lives: scoring, the
/// simulated world acting (a weld attaching, a fault injected). Decisions never open one.
class TruthScope {
 public:
  TruthScope(const Hardware& hw, const char* why) : hw_(hw), why_(why) { hw_.openTruth(); }
  ~TruthScope() { hw_.closeTruth(); }
  TruthScope(const TruthScope&) = delete;
  TruthScope& operator=(const TruthScope&) = delete;
  const char* why() const { return why_; }

 private:
  const Hardware& hw_;
  const char* why_;
};

/// A Hardware that passes every call on to another one; a decorator (fault injection, a test's
/// recorder) overrides only what it changes.
class ForwardingHardware : public Hardware {
 public:
  explicit ForwardingHardware(Hardware& inner) : in_(inner) {}
  Hardware& inner() { return in_; }
  const char* name() const override { return in_.name(); }
  double time() const override { return in_.time(); }
  double period() const override { return in_.period(); }
  VecX jointPositions() const override { return in_.jointPositions(); }
  VecX jointVelocities() const override { return in_.jointVelocities(); }
  double gripperOpening() const override { return in_.gripperOpening(); }
  double gripperForce() const override { return in_.gripperForce(); }
  void write(const VecX& q, const VecX& qd, const VecX& qdd) override { in_.write(q, qd, qdd); }
  VecX commandedPositions() const override { return in_.commandedPositions(); }
  void writeGripper(double opening, double max_force) override { in_.writeGripper(opening, max_force); }
  void step() override { in_.step(); }
  void attach(int i, bool on) override { in_.attach(i, on); }
  void setStiff(bool on) override { in_.setStiff(on); }
  void setPayload(double mass, const Vec3& com_tcp) override { in_.setPayload(mass, com_tcp); }
  bool capture(const std::string& name, int width, int height, Frame& frame, std::string* why) override {
    return in_.capture(name, width, height, frame, why);
  }
  void setCameraSource(CameraSource source) override { in_.setCameraSource(std::move(source)); }
  std::vector<ObjectState> objects() const override { return in_.objects(); }
  ObjectState object(int i) const override { return in_.object(i); }
  Vec3 objectVelocity(int i) const override { return in_.objectVelocity(i); }
  Pose tcpPose() const override { return in_.tcpPose(); }
  std::vector<Obstacle> obstacles() const override { return in_.obstacles(); }
  double externalForce() const override { return in_.externalForce(); }
  double handForce() const override { return in_.handForce(); }
  std::vector<int> objectsTouched() const override { return in_.objectsTouched(); }
  int collisionEvents() const override { return in_.collisionEvents(); }
  const std::vector<std::string>& collisionLog() const override { return in_.collisionLog(); }
  bool unstable() const override { return in_.unstable(); }
  const std::string& instabilityReason() const override { return in_.instabilityReason(); }
  void guardTruth(bool on) override { in_.guardTruth(on); }
  void openTruth() const override { in_.openTruth(); }
  void closeTruth() const override { in_.closeTruth(); }

 protected:
  Hardware& in_;
};

/// The backends by name: "mujoco", "mock".
const std::vector<std::string>& hardwareNames();

/// `active` lists the objects in play this trial (the others are parked off the table).
std::unique_ptr<Hardware> makeMujocoHardware(SimWorld& world, const RobotModel& robot, std::vector<int> active);
std::unique_ptr<Hardware> makeMockHardware(SimWorld& world, const RobotModel& robot, std::vector<int> active);

}  // namespace mm
