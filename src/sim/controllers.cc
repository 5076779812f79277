#include "sim/controllers.h"

#include <cmath>

namespace mm {

ExecutionResult executeTrajectory(Hardware& hw, const JointTrajectory& traj, double gripper_opening,
                                  double gripper_force, const StepMonitor& monitor, double settle) {
  ExecutionResult r;
  const double t0 = hw.time();
  const int n = traj.size();
  hw.writeGripper(gripper_opening, gripper_force);
  auto fail = [&](const std::string& why) {
    r.ok = false;
    r.reason = why;
    r.duration = hw.time() - t0;
    return r;
  };
  // Period k takes the state from sample k to sample k+1: the setpoint is the sample due at the
  // period's end (with the acceleration over the period), and the error is measured there.
  for (int k = 0; k + 1 < n; ++k) {
    hw.write(traj.q.col(k + 1), traj.qd.col(k + 1), traj.qdd.col(k));
    hw.step();
    if (hw.unstable()) return fail("SIM_UNSTABLE: " + hw.instabilityReason());
    r.max_tracking_error = std::max(r.max_tracking_error, (traj.q.col(k + 1) - hw.jointPositions()).cwiseAbs().maxCoeff());
    if (monitor) {
      const std::string why = monitor();
      if (!why.empty()) return fail(why);
    }
  }
  // Hold the final sample until still.
  const VecX q_end = traj.q.col(n - 1), zero = VecX::Zero(traj.q.rows());
  for (double t = 0; t < settle; t += hw.period()) {
    if (hw.jointVelocities().cwiseAbs().maxCoeff() < 1e-3 && (q_end - hw.jointPositions()).cwiseAbs().maxCoeff() < 1e-3) break;
    hw.write(q_end, zero, zero);
    hw.step();
    if (hw.unstable()) return fail("SIM_UNSTABLE: " + hw.instabilityReason());
    if (monitor) {
      const std::string why = monitor();
      if (!why.empty()) return fail(why);
    }
  }
  r.duration = hw.time() - t0;
  return r;
}

GripperResult moveGripper(Hardware& hw, const VecX& q_hold, double opening, double force, double timeout) {
  GripperResult r;
  const double t0 = hw.time();
  const VecX zero = VecX::Zero(q_hold.size());
  hw.writeGripper(opening, force);
  double last = hw.gripperOpening();
  int still = 0;
  while (hw.time() - t0 < timeout) {
    hw.write(q_hold, zero, zero);
    hw.step();
    if (hw.unstable()) {
      r.ok = false;
      r.reason = "SIM_UNSTABLE: " + hw.instabilityReason();
      break;
    }
    const double now = hw.gripperOpening();
    // Done when still (under 5 mm/s) for 10 ms at the goal, or for 50 ms anywhere (blocked by
    // what is between the fingers).
    still = std::abs(now - last) < 5e-3 * hw.period() ? still + 1 : 0;
    last = now;
    const bool at_goal = std::abs(now - opening) < 5e-4;
    if (still >= static_cast<int>((at_goal ? 0.01 : 0.05) / hw.period())) break;
  }
  r.opening = hw.gripperOpening();
  r.duration = hw.time() - t0;
  return r;
}

}  // namespace mm
