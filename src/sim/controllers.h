// Controllers on the hardware interface: a joint trajectory controller that streams a sampled
// trajectory at the control rate (500 Hz), and a gripper controller (goal opening, force limit),
// as ros2_control's JointTrajectoryController and GripperActionController.
#pragma once
#include <functional>
#include <string>

#include "core/joint_trajectory.h"
#include "sim/hardware.h"

namespace mm {

struct ExecutionResult {
  bool ok = true;
  std::string reason;
  double max_tracking_error = 0;  ///< [rad] max over samples and joints of |q_desired - q|
  double duration = 0;            ///< [s] simulated
};

/// A check run after every control period; returning a non-empty reason aborts the execution.
using StepMonitor = std::function<std::string()>;

/// Streams `traj` to the hardware, then holds its last sample for up to `settle` seconds until the
/// joints are still. Aborts on simulator instability or when `monitor` reports a problem.
ExecutionResult executeTrajectory(Hardware& hw, const JointTrajectory& traj, double gripper_opening,
                                  double gripper_force, const StepMonitor& monitor, double settle = 0.3);

struct GripperResult {
  bool ok = true;
  std::string reason;
  double opening = 0;   ///< [m] per finger when done
  double duration = 0;  ///< [s] simulated
};

/// Moves the gripper to `opening` [m] with force limit `force` [N], holding the arm at q_hold;
/// done when the fingers stop (blocked by an object or at the goal), or after `timeout` [s].
GripperResult moveGripper(Hardware& hw, const VecX& q_hold, double opening, double force, double timeout = 1.5);

}  // namespace mm
