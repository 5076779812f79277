#include "sim/controllers.h"

#include <algorithm>
#include <cmath>

namespace mm {

void Motion::begin(const Hardware& hw) {
  started_ = true;
  t0_ = hw.time();
}

void Motion::succeed(const Hardware& hw) {
  state_ = MotionState::kSucceeded;
  duration_ = hw.time() - t0_;
}

void Motion::fail(const Hardware& hw, FailureKind kind, const std::string& reason) { fail(hw, Failure{"", kind, reason}); }

void Motion::fail(const Hardware& hw, Failure failure) {
  state_ = MotionState::kFailed;
  failure_ = std::move(failure);
  duration_ = hw.time() - t0_;
}

// ---- joint trajectory ------------------------------------------------------------------------

TrajectoryMotion::TrajectoryMotion(JointTrajectory traj, double gripper_opening, double gripper_force,
                                   StepMonitor monitor, const RobotModel& robot, double settle, double path_tolerance,
                                   double force_limit, bool guarded)
    : traj_(std::move(traj)), opening_(gripper_opening), force_(gripper_force), monitor_(std::move(monitor)),
      robot_(robot), settle_(settle), path_tolerance_(path_tolerance), force_limit_(force_limit), guarded_(guarded) {}

// Period k takes the state from sample k to sample k+1: the setpoint is the sample due at the
// period's end (with the acceleration over the period), and the error is measured there. Then the
// last sample is held until the joints are still.
bool TrajectoryMotion::command(Hardware& hw) {
  if (!started()) {
    begin(hw);
    hw.writeGripper(opening_, force_);
  }
  const int n = traj_.size();
  if (n == 0) {
    succeed(hw);
    return false;
  }
  if (streaming_) {
    if (k_ + 1 < n) {
      hw.write(traj_.q.col(k_ + 1), traj_.qd.col(k_ + 1), traj_.qdd.col(k_));
      return true;
    }
    streaming_ = false;
    if (settle_opening_ >= 0 && pending_.ok() && !touched_down_) hw.writeGripper(settle_opening_, settle_force_);
  }
  const VecX q_end = traj_.q.col(n - 1);
  // After a stop the arm is always held until still (at most 0.3 s), whatever comes next.
  const double settle = pending_.ok() ? settle_ : std::max(settle_, 0.3);
  if (!(t_settle_ < settle) ||
      (hw.jointVelocities().cwiseAbs().maxCoeff() < settle_qd_ && (q_end - hw.jointPositions()).cwiseAbs().maxCoeff() < settle_q_)) {
    if (pending_.ok()) succeed(hw);
    else fail(hw, pending_);
    return false;
  }
  const VecX zero = VecX::Zero(traj_.q.rows());
  hw.write(q_end, zero, zero);
  return true;
}

void TrajectoryMotion::observe(Hardware& hw) {
  if (hw.unstable()) return fail(hw, FailureKind::kSimUnstable, "SIM_UNSTABLE: " + hw.instabilityReason());
  if (streaming_) {
    Eigen::Index joint = 0;
    const double error = (traj_.q.col(k_ + 1) - hw.jointPositions()).cwiseAbs().maxCoeff(&joint);
    max_tracking_error_ = std::max(max_tracking_error_, error);
    if (path_tolerance_ > 0 && error > path_tolerance_ && pending_.ok()) {
      pending_ = {"", FailureKind::kTracking,
                  "joint " + std::to_string(joint + 1) + " " + std::to_string(error) + " rad from its path (tolerance " +
                      std::to_string(path_tolerance_) + " rad)"};
      stop(hw);
    }
  }
  if (force_limit_ > 0 && pending_.ok() && !touched_down_) {
    const double force = hw.externalForce();
    // Touch-down is the hand (and what it holds) meeting the surface; a force on another link
    // past the limit is a collision even in a guarded move.
    if (force > force_limit_ && guarded_ && hw.handForce() >= force) {
      // Touch-down: hold here (the settle below), then succeed.
      touched_down_ = true;
      traj_ = JointTrajectory::startingAt(hw.jointPositions(), 1, traj_.dt);
      streaming_ = false;
      k_ = 0;
    } else if (std::min(force, last_force_) > force_limit_) {
      // Past the limit for two control periods (4 ms), as a robot's collision reflex acts on a
      // filtered force estimate: a contact's one-step impulse (a stiff pad meeting a cube) is not a collision.
      pending_ = {"", FailureKind::kContactForce,
                  "protective stop: " + std::to_string(force) + " N of contact force (limit " + std::to_string(force_limit_) + " N)"};
      stop(hw);
    }
    last_force_ = force;
  }
  if (monitor_ && pending_.ok()) {
    pending_ = monitor_();
    if (!pending_.ok()) stop(hw);
  }
  if (streaming_) ++k_;
  else t_settle_ += hw.period();
}

// Called from observe(), before k_ moves on: the joints were just sent to sample k_ + 1. After a
// tracking error the stop is shifted onto where the joints are (as ros2_control's JTC holds the
// measured position when it aborts): an arm held back by a contact is not pushed on into it, and
// the next motion starts where it really is.
void TrajectoryMotion::stop(Hardware& hw) {
  const bool tracking = pending_.kind == FailureKind::kTracking;
  const VecX offset = tracking ? VecX(hw.jointPositions() - traj_.q.col(std::min(k_ + 1, traj_.size() - 1))) : VecX();
  if (pending_.kind == FailureKind::kContactForce) {
    // A collision reflex: hold where the joints are now, braking at once (a controlled stop along
    // the path would press on into what was hit), at the high joint impedance, as brakes hold: at
    // the servo's own gains a wedged object pushes the wrist centimetres aside (into a bin's wall).
    // The next step sets the gains it needs.
    hw.setStiff(true);
    traj_ = JointTrajectory::startingAt(hw.jointPositions(), 1, traj_.dt);
    streaming_ = false;
    k_ = 0;
    return;
  }
  const JointTrajectory& along = stop_path_.empty() ? traj_ : stop_path_;
  if (streaming_ && k_ + 2 < along.size()) {
    traj_ = controlledStop(along, k_ + 1, robot_.vmax(), robot_.amax(), robot_.jmax());
    stop_path_ = JointTrajectory{};
    k_ = -1;  // observe() moves it onto sample 0 of the stop, where the joints are being sent
  } else if (tracking) {
    traj_ = JointTrajectory::startingAt(traj_.q.col(std::min(k_ + 1, traj_.size() - 1)), 1, traj_.dt);
    streaming_ = false;
  }
  if (tracking) traj_.q.colwise() += offset;
}

void TrajectoryMotion::halt(Hardware& hw) {
  if (!running()) return;
  halted_ = true;
  if (!started()) return succeed(hw);
  const JointTrajectory& along = stop_path_.empty() ? traj_ : stop_path_;
  if (streaming_ && k_ + 1 < along.size()) {
    traj_ = controlledStop(along, k_, robot_.vmax(), robot_.amax(), robot_.jmax());
    stop_path_ = JointTrajectory{};
    k_ = 0;
    return;  // the stop streams, then the settle holds its end
  }
  if (pending_.ok()) succeed(hw);  // already holding the end at rest
  else fail(hw, pending_);
}

// ---- gripper ---------------------------------------------------------------------------------

GripperMotion::GripperMotion(VecX q_hold, double opening, double force, double timeout)
    : q_hold_(std::move(q_hold)), opening_(opening), force_(force), timeout_(timeout) {}

bool GripperMotion::command(Hardware& hw) {
  if (!started()) {
    begin(hw);
    hw.writeGripper(opening_, force_);
    last_ = hw.gripperOpening();
  }
  if (!(hw.time() - startTime() < timeout_)) {
    final_opening_ = hw.gripperOpening();
    succeed(hw);
    return false;
  }
  const VecX zero = VecX::Zero(q_hold_.size());
  hw.write(q_hold_, zero, zero);
  return true;
}

void GripperMotion::observe(Hardware& hw) {
  final_opening_ = hw.gripperOpening();
  if (hw.unstable()) return fail(hw, FailureKind::kSimUnstable, "SIM_UNSTABLE: " + hw.instabilityReason());
  // Done when still (under 5 mm/s) for 10 ms at the goal, or for 50 ms anywhere (blocked by
  // what is between the fingers).
  const double now = final_opening_;
  still_ = std::abs(now - last_) < 5e-3 * hw.period() ? still_ + 1 : 0;
  last_ = now;
  const bool at_goal = std::abs(now - opening_) < 5e-4;
  if (clear_at_ > 0 && now >= clear_at_) return succeed(hw);
  if (still_ >= static_cast<int>((at_goal ? 0.01 : 0.05) / hw.period())) succeed(hw);
}

void GripperMotion::halt(Hardware& hw) {
  if (!running()) return;
  halted_ = true;
  final_opening_ = hw.gripperOpening();
  hw.writeGripper(final_opening_, force_);  // the fingers stay where they are
  succeed(hw);
}

// ---- hold ------------------------------------------------------------------------------------

HoldMotion::HoldMotion(VecX q, double opening, double force, double seconds)
    : q_(std::move(q)), opening_(opening), force_(force), seconds_(seconds) {}

bool HoldMotion::command(Hardware& hw) {
  if (!started()) {
    begin(hw);
    hw.writeGripper(opening_, force_);
  }
  if (!(hw.time() - startTime() < seconds_)) {
    succeed(hw);
    return false;
  }
  const VecX zero = VecX::Zero(q_.size());
  hw.write(q_, zero, zero);
  return true;
}

void HoldMotion::observe(Hardware& hw) {
  if (hw.unstable()) fail(hw, FailureKind::kSimUnstable, "SIM_UNSTABLE: " + hw.instabilityReason());
}

void HoldMotion::halt(Hardware& hw) {
  if (!running()) return;
  halted_ = true;
  succeed(hw);
}

void runToEnd(Hardware& hw, Motion& m) {
  while (m.running() && m.command(hw)) {
    hw.step();
    m.observe(hw);
  }
}

// ---- controlled stop -------------------------------------------------------------------------

namespace {

// The trajectory at time tau [s] (clamped to its span): position by cubic Hermite between the
// samples (consistent with their velocities), velocity and acceleration linearly.
struct Sampled {
  VecX q, qd, qdd;
};
void sampleAt(const JointTrajectory& t, double tau, Sampled& s) {
  const int n = t.size();
  const double dt = t.dt;
  const double x = std::clamp(tau / dt, 0.0, static_cast<double>(n - 1));
  const int i = std::min(static_cast<int>(std::floor(x)), n - 2);
  if (n < 2) {
    s.q = t.q.col(0), s.qd = t.qd.col(0), s.qdd = t.qdd.col(0);
    return;
  }
  const double f = x - i;
  const double h00 = 2 * f * f * f - 3 * f * f + 1, h10 = f * f * f - 2 * f * f + f, h01 = -2 * f * f * f + 3 * f * f,
               h11 = f * f * f - f * f;
  s.q = h00 * t.q.col(i) + h10 * dt * t.qd.col(i) + h01 * t.q.col(i + 1) + h11 * dt * t.qd.col(i + 1);
  s.qd = (1 - f) * t.qd.col(i) + f * t.qd.col(i + 1);
  s.qdd = (1 - f) * t.qdd.col(i) + f * t.qdd.col(i + 1);
}

}  // namespace

JointTrajectory controlledStop(const JointTrajectory& traj, int k, const VecX& vmax, const VecX& amax,
                               const VecX& jmax) {
  const int n = traj.size(), dof = static_cast<int>(traj.q.rows());
  const double dt = traj.dt, t_k = k * dt, remaining = traj.duration() - t_k;
  auto remainder = [&] {
    JointTrajectory r;
    r.dt = dt;
    r.q = traj.q.rightCols(n - k);
    r.qd = traj.qd.rightCols(n - k);
    r.qdd = traj.qdd.rightCols(n - k);
    return r;
  };
  // A lower bound on T: the deceleration qd * s' peaks at 1.5 |qd| / T, and the jerk qd * s''
  // starts at 6 |qd| / T^2.
  double T = 4 * dt;
  for (int j = 0; j < dof; ++j) {
    const double v = std::abs(traj.qd(j, k));
    T = std::max({T, 1.5 * v / amax[j], std::sqrt(6 * v / jmax[j])});
  }
  constexpr double kTol = 1e-9;
  Sampled s;
  for (int attempt = 0; attempt < 200; ++attempt, T *= 1.1) {
    const int M = static_cast<int>(std::ceil(T / dt - 1e-9));
    const double Tq = M * dt;
    if (Tq / 2 >= remaining) return remainder();  // the trajectory's own end comes first
    JointTrajectory stop;
    stop.dt = dt;
    stop.q.resize(dof, M + 1), stop.qd.resize(dof, M + 1), stop.qdd.resize(dof, M + 1);
    bool ok = true;
    for (int m = 0; m <= M && ok; ++m) {
      const double u = static_cast<double>(m) / M;
      const double sigma = 1 - 3 * u * u + 2 * u * u * u;
      const double sigma_d = (-6 * u + 6 * u * u) / Tq;
      const double tau = t_k + Tq * (u - u * u * u + 0.5 * u * u * u * u);
      sampleAt(traj, tau, s);
      stop.q.col(m) = s.q;
      stop.qd.col(m) = s.qd * sigma;
      stop.qdd.col(m) = s.qdd * sigma * sigma + s.qd * sigma_d;
      for (int j = 0; j < dof && ok; ++j) {
        ok = std::abs(stop.qd(j, m)) <= vmax[j] * (1 + kTol) && std::abs(stop.qdd(j, m)) <= amax[j] * (1 + kTol);
        if (ok && m > 0) ok = std::abs(stop.qdd(j, m) - stop.qdd(j, m - 1)) / dt <= jmax[j] * (1 + kTol);
      }
    }
    if (!ok) continue;
    stop.q.col(0) = traj.q.col(k);  // exactly where the joints were being sent (Hermite at f = 0)
    return stop;
  }
  return remainder();
}

// ---- blocking forms --------------------------------------------------------------------------

ExecutionResult executeTrajectory(Hardware& hw, const JointTrajectory& traj, double gripper_opening,
                                  double gripper_force, const StepMonitor& monitor, const RobotModel& robot,
                                  double settle) {
  TrajectoryMotion m(traj, gripper_opening, gripper_force, monitor, robot, settle);
  runToEnd(hw, m);
  ExecutionResult r;
  r.ok = m.state() == MotionState::kSucceeded;
  r.reason = m.failure().reason;
  r.max_tracking_error = m.maxTrackingError();
  r.duration = m.duration();
  return r;
}

GripperResult moveGripper(Hardware& hw, const VecX& q_hold, double opening, double force, double timeout) {
  GripperMotion m(q_hold, opening, force, timeout);
  runToEnd(hw, m);
  GripperResult r;
  r.ok = m.state() == MotionState::kSucceeded;
  r.reason = m.failure().reason;
  r.opening = m.opening();
  r.duration = m.duration();
  return r;
}

}  // namespace mm
