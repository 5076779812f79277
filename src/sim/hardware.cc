#include "sim/hardware.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "sim/sim_world.h"

namespace mm {
namespace {

class HardwareBase : public Hardware {
 public:
  HardwareBase(SimWorld& w, const RobotModel& r, std::vector<int> active)
      : w_(w), robot_(r), active_(std::move(active)), q_cmd_(r.home()), qd_cmd_(VecX::Zero(r.dof())),
        qdd_cmd_(VecX::Zero(r.dof())), grip_target_(r.spec().gripper.travel), grip_force_(r.spec().gripper.max_force) {
    q_cmd_ = w.armPositions();
  }
  double time() const override { return w_.time(); }
  double period() const override { return w_.controlPeriod(); }
  VecX jointPositions() const override { return w_.armPositions(); }
  double gripperOpening() const override { return w_.fingerOpening(); }
  void write(const VecX& q, const VecX& qd, const VecX& qdd) override { q_cmd_ = q, qd_cmd_ = qd, qdd_cmd_ = qdd; }
  VecX commandedPositions() const override { return q_cmd_; }
  void writeGripper(double opening, double max_force) override { grip_target_ = opening, grip_force_ = max_force; }
  std::vector<ObjectState> objects() const override {
    checkTruth("objects()");
    std::vector<ObjectState> out;
    for (int i : active_) out.push_back(w_.object(i));
    return out;
  }
  ObjectState object(int i) const override {
    checkTruth("object()");
    return w_.object(i);
  }
  bool capture(const std::string& name, int width, int height, Frame& frame, std::string* why) override {
    if (!camera_) {
      *why = "no camera source (rendering is not set up)";
      return false;
    }
    return camera_(name, width, height, frame, why);
  }
  void setCameraSource(CameraSource source) override { camera_ = std::move(source); }
  Pose tcpPose() const override {
    checkTruth("tcpPose()");
    return w_.tcpPose();
  }
  std::vector<Obstacle> obstacles() const override {
    checkTruth("obstacles()");
    return w_.placedObstacles();
  }
  std::vector<int> objectsTouched() const override {
    checkTruth("objectsTouched()");
    return w_.objectsTouched();
  }
  void guardTruth(bool on) override { guarded_ = on; }
  void openTruth() const override { ++scopes_; }
  void closeTruth() const override { --scopes_; }
  int collisionEvents() const override { return w_.collisionEvents(); }
  const std::vector<std::string>& collisionLog() const override { return w_.collisionLog(); }
  bool unstable() const override { return w_.unstable(); }
  const std::string& instabilityReason() const override { return w_.instabilityReason(); }

 protected:
  SimWorld& w_;
  const RobotModel& robot_;
  std::vector<int> active_;
  VecX q_cmd_, qd_cmd_, qdd_cmd_;
  double grip_target_, grip_force_;
  CameraSource camera_;
  bool guarded_ = false;
  mutable int scopes_ = 0;

  void checkTruth(const char* what) const {
    if (guarded_ && scopes_ <= 0)
      throw std::logic_error(std::string("the simulator's truth (") + what +
                             ") read outside a TruthScope in camera mode: a decision must not rest on it");
  }
};

class MujocoHardware final : public HardwareBase {
 public:
  MujocoHardware(SimWorld& w, const RobotModel& r, std::vector<int> active)
      : HardwareBase(w, r, std::move(active)), q_ref_(w.armPositions()), qd_ref_(VecX::Zero(r.dof())) {}
  const char* name() const override { return "mujoco"; }
  VecX jointVelocities() const override { return w_.armVelocities(); }
  double gripperForce() const override { return w_.fingerForce(); }
  Vec3 objectVelocity(int i) const override {
    checkTruth("objectVelocity()");
    return w_.objectVelocity(i);
  }
  double externalForce() const override { return w_.externalForce(); }
  double handForce() const override { return w_.handForce(); }
  // The setpoint is where the joints should be at the end of the period; the servo tracks the
  // reference at its start (the previous setpoint) with the period's acceleration as feed-forward.
  void step() override {
    w_.stepServo(q_ref_, qd_ref_, qdd_cmd_, grip_target_, grip_force_);
    q_ref_ = q_cmd_;
    qd_ref_ = qd_cmd_;
  }

 private:
  VecX q_ref_, qd_ref_;
  void attach(int i, bool on) override { w_.setWeld(i, on); }
  void setStiff(bool on) override { w_.setStiff(on); }
  void setPayload(double mass, const Vec3& com_tcp) override { w_.setPayload(mass, com_tcp); }
};

// Joints follow commands exactly; the fingers move at their speed limit and stop on an object;
// an object moves only while it is held, and when released it comes to rest on the surface below.
class MockHardware final : public HardwareBase {
 public:
  MockHardware(SimWorld& w, const RobotModel& r, std::vector<int> active) : HardwareBase(w, r, std::move(active)) {}
  const char* name() const override { return "mock"; }
  VecX jointVelocities() const override { return qd_cmd_; }
  double gripperForce() const override { return held_ >= 0 ? grip_force_ : 0.0; }
  Vec3 objectVelocity(int i) const override {
    checkTruth("objectVelocity()");
    return i == held_ ? held_velocity_ : Vec3::Zero();
  }
  double externalForce() const override { return 0; }  // kinematic: no forces
  double handForce() const override { return 0; }
  void attach(int, bool) override {}  // a held object already moves with the hand
  void setStiff(bool) override {}     // joints follow commands exactly
  void setPayload(double, const Vec3&) override {}

  void step() override {
    const Pose T_before = w_.tcpPose();
    w_.setArm(q_cmd_);
    w_.updateKinematics();
    // Fingers.
    const double dt = period();
    const double v = robot_.spec().gripper.velocity;
    double opening = w_.fingerOpening();
    const double target = grip_target_;
    opening = target > opening ? std::min(target, opening + v * dt) : std::max(target, opening - v * dt);
    if (target < opening + 1e-12 && held_ < 0) {
      // Closing: an object between the fingers stops them at its half width.
      const int k = objectBetweenFingers();
      if (k >= 0 && opening <= halfWidthAcrossFingers(k) + 1e-9) {
        opening = halfWidthAcrossFingers(k);
        held_ = k;
        T_tcp_held_ = w_.tcpPose().inverse() * w_.object(k).T_world_object;
      }
    }
    if (held_ >= 0 && target > opening) release();  // opening lets go
    if (held_ >= 0) {
      opening = std::max(opening, halfWidthAcrossFingers(held_));
      const Pose T = w_.tcpPose() * T_tcp_held_;
      held_velocity_ = (T.translation() - (T_before * T_tcp_held_).translation()) / dt;
      w_.setObjectPose(held_, T);
    }
    w_.setFingers(opening);
    w_.stepKinematic();  // one period: time advances once, contacts for the monitors
  }

 private:
  // How far the finger's shapes reach across the pad (along the hand's x) [m].
  double padHalfWidth() const {
    double h = 0;
    for (const ShapeSpec& sh : robot_.spec().gripper.fingers[0].shapes) {
      if (sh.type == ShapeSpec::Type::kBox) h = std::max(h, std::abs(sh.pos[0]) + sh.half[0]);
      else if (sh.type == ShapeSpec::Type::kSphere) h = std::max(h, std::abs(sh.pos[0]) + sh.radius);
      else h = std::max(h, std::max(std::abs(sh.from[0]), std::abs(sh.to[0])) + sh.radius);
    }
    return h;
  }
  // The object whose center lies between the finger pads (within the pad depth), or -1.
  int objectBetweenFingers() const {
    const Pose T_tcp = w_.tcpPose();
    for (int k : active_) {
      const Vec3 p = T_tcp.inverse() * w_.object(k).T_world_object.translation();
      if (std::abs(p.x()) < padHalfWidth() + 0.0015 && std::abs(p.z()) < 0.02 && std::abs(p.y()) < robot_.spec().gripper.travel)
        return k;
    }
    return -1;
  }
  double halfWidthAcrossFingers(int k) const {
    const ObjectState o = w_.object(k);
    const Vec3 y = w_.tcpPose().linear().col(1);
    const Mat3 R = o.T_world_object.linear();
    double h = 0;
    if (o.shape == ObjectShape::kCylinder) {
      const double c = std::min(1.0, std::abs(y.dot(R.col(2))));
      return o.half_size.x() * std::sqrt(1 - c * c) + o.half_size.z() * c;
    }
    if (o.shape == ObjectShape::kMesh && o.pieces) {  // its hull's extent along the closing line
      const Vec3 y_local = R.transpose() * y;
      double lo = INFINITY, hi = -INFINITY;
      for (const ConvexPiece& piece : *o.pieces)
        for (const Vec3& v : piece.vertices) lo = std::min(lo, v.dot(y_local)), hi = std::max(hi, v.dot(y_local));
      return (hi - lo) / 2;
    }
    for (int a = 0; a < 3; ++a) h += std::abs(y.dot(R.col(a))) * o.half_size[a];
    return h;
  }
  void release() {
    ObjectState o = w_.object(held_);
    // Falls straight down onto the first surface below its lowest point (it keeps its yaw).
    const double support = w_.surfaceBelow(o.T_world_object.translation(), held_);
    Pose T = o.T_world_object;
    const double yaw = yawOf(T.linear());
    T.linear() = rotZ(yaw);
    T.translation().z() = support + o.half_size.z();
    w_.setObjectPose(held_, T);
    held_ = -1;
    held_velocity_.setZero();
  }

  int held_ = -1;
  Pose T_tcp_held_ = Pose::Identity();
  Vec3 held_velocity_ = Vec3::Zero();
};

}  // namespace

const std::vector<std::string>& hardwareNames() {
  static const std::vector<std::string> names = {"mujoco", "mock"};
  return names;
}

std::unique_ptr<Hardware> makeMujocoHardware(SimWorld& world, const RobotModel& robot, std::vector<int> active) {
  return std::make_unique<MujocoHardware>(world, robot, std::move(active));
}
std::unique_ptr<Hardware> makeMockHardware(SimWorld& world, const RobotModel& robot, std::vector<int> active) {
  return std::make_unique<MockHardware>(world, robot, std::move(active));
}

}  // namespace mm
