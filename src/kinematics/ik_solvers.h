// Constructors of the IK solvers (used by makeIkSolver); each in its own .cc file.
#pragma once
#include <chrono>
#include <memory>
#include <vector>

#include "kinematics/ik.h"

namespace mm {

std::unique_ptr<IkSolver> makeDlsSolver(const RobotModel& robot);
/// The closed form the robot declares (RobotSpec::analytic_ik): the Panda's or the UR family's.
std::unique_ptr<IkSolver> makeAnalyticSolver(const RobotModel& robot, bool polish_with_dls);
std::unique_ptr<IkSolver> makeUrAnalyticSolver(const RobotModel& robot, bool polish_with_dls);
std::unique_ptr<IkSolver> makeKdlSolver(const RobotModel& robot, bool restarts);
std::unique_ptr<IkSolver> makeTracIkSolver(const RobotModel& robot, bool distance_mode);

/// orocos-KDL's forward kinematics of the chain the KDL-based solvers build (for tests).
Pose kdlForwardKinematics(const RobotModel& robot, const VecX& q);

/// The damped least squares iteration from one start, for reuse (hybrid, TRAC-IK comparisons):
/// returns true on convergence to the request's tolerances; `q` holds the last iterate.
/// `iterations` counts FK+Jacobian evaluations.
class FastChain;
bool dlsDescend(const FastChain& chain, const VecX& lower, const VecX& upper, const Mat3& R_target,
                const Vec3& p_target, const IkRequest& req, int max_iterations, VecX& q, long& iterations);

/// The hybrids' fallback: descends (dlsDescend, 60 iterations each) from each of `starts` clamped
/// into the limits, then from random configurations, adding solutions to `r` until it holds
/// max_solutions or the attempts or iterations run out; the wall-clock cap is checked every 8
/// starts from `t0`.
void descendFromStarts(const RobotModel& robot, const FastChain& chain, const IkRequest& req,
                       const std::vector<VecX>& starts, Rng& rng, std::chrono::steady_clock::time_point t0, IkResult& r);

}  // namespace mm
