// Inverse kinematics behind one interface. Failures are values (status + reason), never throws.
// Each solve is deterministic for a given seed configuration, RNG stream and iteration budget.
#pragma once
#include <string>

#include "core/pose.h"
#include "core/rng.h"
#include "robot/robot_model.h"

namespace mm {

enum class IkStatus { kSuccess, kNoSolution, kInvalidInput };

struct IkOptions {
  int max_iterations = 100;      ///< per attempt
  int max_attempts = 30;         ///< first from the seed, then random restarts
  double tol_position = 1e-5;    ///< [m]
  double tol_rotation = 1e-4;    ///< [rad]
  double limit_margin = 0.0;     ///< solutions keep this far from joint limits [rad]
  double damping = 1e-3;         ///< DLS damping lambda
};

struct IkResult {
  IkStatus status = IkStatus::kNoSolution;
  VecX q;                  ///< the solution (dim dof) when status is kSuccess
  std::string reason;
  int iterations = 0;      ///< over all attempts
  int attempts = 0;
  double position_error = 0;  ///< [m]
  double rotation_error = 0;  ///< [rad]
  bool ok() const { return status == IkStatus::kSuccess; }
};

/// Damped least squares (Levenberg–Marquardt style) on the geometric Jacobian, with joint limits
/// by clamping and random restarts drawn from `rng`. Wampler 1986; Buss 2004 (survey).
IkResult solveIkDls(const RobotModel& robot, const Pose& T_base_tcp, const VecX& seed, Rng& rng,
                    const IkOptions& options = {});

}  // namespace mm
