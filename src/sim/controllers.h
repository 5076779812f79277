// Controllers on the hardware interface, as ros2_control's JointTrajectoryController and
// GripperActionController: a joint trajectory streamed at the control rate (500 Hz), a gripper
// goal with a force limit, and holding still. Each is a Motion advanced one control period at a
// time, so a behavior tree can run on simulated time above it and halt it mid-motion; a halted
// arm motion ends in a controlled stop along its path within the arm's unscaled limits.
#pragma once
#include <functional>
#include <string>

#include "core/failure.h"
#include "core/joint_trajectory.h"
#include "sim/hardware.h"

namespace mm {

/// A check run after every control period; a failure (kind not kNone) aborts the motion.
using StepMonitor = std::function<Failure()>;

enum class MotionState { kRunning, kSucceeded, kFailed };

/// One motion of the arm and gripper, advanced one control period at a time by its owner:
///   while (m.command(hw)) { hw.step(); m.observe(hw); if (m.state() != kRunning) break; }
/// command() writes the period's setpoints and returns true, or ends the motion (state() tells
/// how) and returns false without using the period; observe() checks the stepped state.
class Motion {
 public:
  virtual ~Motion() = default;
  virtual bool command(Hardware& hw) = 0;
  virtual void observe(Hardware& hw) = 0;
  /// Stop as soon as the limits allow: the arm decelerates along its path to rest (the motion
  /// then ends as succeeded with halted() true); the gripper stays where it is.
  virtual void halt(Hardware& hw) = 0;

  MotionState state() const { return state_; }
  bool running() const { return state_ == MotionState::kRunning; }
  bool halted() const { return halted_; }
  /// Why it failed (kind kNone unless state() is kFailed); the owner fills in the stage.
  const Failure& failure() const { return failure_; }
  double duration() const { return duration_; }  ///< [s] simulated, from the first period to the end
  double maxTrackingError() const { return max_tracking_error_; }  ///< [rad]

 protected:
  void begin(const Hardware& hw);
  void succeed(const Hardware& hw);
  void fail(const Hardware& hw, FailureKind kind, const std::string& reason);
  void fail(const Hardware& hw, Failure failure);
  bool started() const { return started_; }
  double startTime() const { return t0_; }

  bool halted_ = false;
  double max_tracking_error_ = 0;

 private:
  MotionState state_ = MotionState::kRunning;
  Failure failure_;
  bool started_ = false;
  double t0_ = 0, duration_ = 0;
};

/// Streams a sampled trajectory, then holds its last sample for up to `settle` seconds until the
/// joints are still. Fails on simulator instability (at once) or when `monitor` reports a problem
/// (after a controlled stop, as after a halt). `robot` gives the unscaled limits a stop keeps within.
class TrajectoryMotion final : public Motion {
 public:
  /// `path_tolerance` [rad]: a joint farther than this from its setpoint fails the motion (kTracking,
  /// after a controlled stop), as ros2_control's JTC aborts on its path tolerance; 0: off.
  /// `force_limit` [N]: an external contact force (Hardware::externalForce) past it fails the motion
  /// (kContactForce), holding where the joints are, as a collision reflex; 0: off. `guarded`: a
  /// guarded move (a place descent): that force ends the motion where it is as a success (touch-down).
  TrajectoryMotion(JointTrajectory traj, double gripper_opening, double gripper_force, StepMonitor monitor,
                   const RobotModel& robot, double settle = 0.3, double path_tolerance = 0, double force_limit = 0,
                   bool guarded = false);
  bool touchedDown() const { return touched_down_; }  ///< a guarded move ended on contact
  /// Still means every joint within `position` [rad] of the last sample and slower than
  /// `velocity` [rad/s] (both 1e-3 unless set).
  void setSettleTolerance(double position, double velocity) { settle_q_ = position, settle_qd_ = velocity; }
  /// Once the last sample is sent (the settle begins), command the gripper to `opening` with
  /// `force`: the next step's close starts while the arm settles.
  void closeWhileSettling(double opening, double force) { settle_opening_ = opening, settle_force_ = force; }
  /// A trajectory cut short to hand on while moving (blended into the next, planning/blend.h):
  /// `path` is the whole of it, ending at rest, of which it is the start; a halt or a monitor's
  /// stop brakes along that path (the cut one's end is no place to stop).
  void stopAlong(JointTrajectory path) { stop_path_ = std::move(path); }
  bool command(Hardware& hw) override;
  void observe(Hardware& hw) override;
  void halt(Hardware& hw) override;
  /// Every sample streamed so far is from this trajectory (replaced by the stop after a halt).
  const JointTrajectory& trajectory() const { return traj_; }

 private:
  JointTrajectory traj_;
  JointTrajectory stop_path_;  // empty: traj_ itself
  double opening_, force_;
  StepMonitor monitor_;
  const RobotModel& robot_;
  double settle_, path_tolerance_, force_limit_;
  double last_force_ = 0;  // the previous period's external force [N]
  double settle_q_ = 1e-3, settle_qd_ = 1e-3;
  double settle_opening_ = -1, settle_force_ = 0;
  bool guarded_ = false, touched_down_ = false;
  int k_ = 0;            // the sample the joints were last sent to
  bool streaming_ = true;
  double t_settle_ = 0;
  Failure pending_;      // the monitor's failure, reported once the stop is done
  void stop(Hardware& hw);
};

/// Moves the gripper to `opening` [m] with force limit `force` [N], holding the arm at q_hold;
/// done when the fingers stop (blocked by an object or at the goal), or after `timeout` [s].
class GripperMotion final : public Motion {
 public:
  GripperMotion(VecX q_hold, double opening, double force, double timeout = 1.5);
  bool command(Hardware& hw) override;
  void observe(Hardware& hw) override;
  void halt(Hardware& hw) override;
  double opening() const { return final_opening_; }  ///< [m] per finger when done
  /// Opening: done as soon as the fingers are this far open [m per finger], still moving on to
  /// the goal (a release hands on to the retreat once the pads have left the object).
  void doneWhenOpenTo(double opening) { clear_at_ = opening; }

 private:
  VecX q_hold_;
  double opening_, force_, timeout_;
  double clear_at_ = -1;
  double last_ = 0, final_opening_ = 0;
  int still_ = 0;
};

/// Holds the arm at q with the gripper commanded to `opening` for `seconds` of simulated time.
class HoldMotion final : public Motion {
 public:
  HoldMotion(VecX q, double opening, double force, double seconds);
  bool command(Hardware& hw) override;
  void observe(Hardware& hw) override;
  void halt(Hardware& hw) override;

 private:
  VecX q_;
  double opening_, force_, seconds_;
};

/// Runs `m` to its end on `hw` (blocking), one period at a time.
void runToEnd(Hardware& hw, Motion& m);

/// The controlled stop of `traj` from sample k (the state the joints are being sent to): the same
/// path, its speed brought to rest by a time scaling s'(t) = 1 - 3u^2 + 2u^3 (u = t/T), with T the
/// shortest (in whole periods) that keeps every joint within `vmax`, `amax` and `jmax` (the
/// robot's unscaled limits [rad/s, rad/s^2, rad/s^3]). Where the trajectory ends sooner than such
/// a stop would, its own remainder is the stop. Sample 0 of the result is sample k of `traj`.
JointTrajectory controlledStop(const JointTrajectory& traj, int k, const VecX& vmax, const VecX& amax,
                               const VecX& jmax);

// Blocking forms (tests and tools).
struct ExecutionResult {
  bool ok = true;
  std::string reason;
  double max_tracking_error = 0;  ///< [rad] max over samples and joints of |q_desired - q|
  double duration = 0;            ///< [s] simulated
};
ExecutionResult executeTrajectory(Hardware& hw, const JointTrajectory& traj, double gripper_opening,
                                  double gripper_force, const StepMonitor& monitor, const RobotModel& robot,
                                  double settle = 0.3);
struct GripperResult {
  bool ok = true;
  std::string reason;
  double opening = 0;   ///< [m] per finger when done
  double duration = 0;  ///< [s] simulated
};
GripperResult moveGripper(Hardware& hw, const VecX& q_hold, double opening, double force, double timeout = 1.5);

}  // namespace mm
