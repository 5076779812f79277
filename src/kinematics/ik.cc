#include "kinematics/ik.h"

#include <cmath>

#include "core/error.h"
#include "kinematics/chain.h"
#include "kinematics/ik_solvers.h"

namespace mm {

std::vector<std::string> ikSolverNames() {
  return {"auto", "analytic", "dls", "hybrid", "kdl", "kdl_restarts", "trac_ik", "trac_ik_distance"};
}

std::unique_ptr<IkSolver> makeIkSolver(const std::string& name, const RobotModel& robot) {
  if (name == "auto") return robot.spec().analytic_ik.empty() ? makeDlsSolver(robot) : makeAnalyticSolver(robot, false);
  if (name == "analytic") return makeAnalyticSolver(robot, false);
  if (name == "hybrid") return makeAnalyticSolver(robot, true);
  if (name == "dls") return makeDlsSolver(robot);
  if (name == "kdl") return makeKdlSolver(robot, false);
  if (name == "kdl_restarts") return makeKdlSolver(robot, true);
  if (name == "trac_ik") return makeTracIkSolver(robot, false);
  if (name == "trac_ik_distance") return makeTracIkSolver(robot, true);
  std::string known;
  for (const auto& n : ikSolverNames()) known += (known.empty() ? "" : ", ") + n;
  throw InputError("ik solver '" + name + "'", "unknown solver (expected one of " + known + ")");
}

int closestSolution(const IkResult& r, const VecX& reference) {
  int best = -1;
  double d = INFINITY;
  for (size_t i = 0; i < r.solutions.size(); ++i) {
    const double di = (r.solutions[i].q - reference).cwiseAbs().maxCoeff();
    if (di < d) d = di, best = static_cast<int>(i);
  }
  return best;
}

bool validRequest(const RobotModel& robot, const IkRequest& req, IkResult& r) {
  if (req.seed.size() != robot.dof() || !req.seed.allFinite() || !req.target.matrix().allFinite()) {
    r.status = IkStatus::kInvalidInput;
    r.reason = "non-finite target or seed, or a seed of the wrong size";
    return false;
  }
  const Mat3 R = req.target.linear();
  if ((R.transpose() * R - Mat3::Identity()).norm() > 1e-6 || R.determinant() < 0) {
    r.status = IkStatus::kInvalidInput;
    r.reason = "target orientation is not a rotation";
    return false;
  }
  return true;
}

bool addSolution(IkResult& r, const RobotModel& robot, const IkRequest& req, const VecX& q) {
  if (!robot.withinLimits(q, req.limit_margin - 1e-12)) return false;
  const Pose T = robot.fk(q);
  // The log map, not acos of the trace: acos cannot resolve angles under ~1e-8 rad.
  const auto e = poseError(req.target.linear(), req.target.translation(), T.linear(), T.translation());
  const double ep = e.head<3>().norm(), er = e.tail<3>().norm();
  if (ep > req.tol_position || er > req.tol_rotation) return false;
  for (const auto& s : r.solutions)
    if ((s.q - q).cwiseAbs().maxCoeff() < req.distinct) return false;
  if (req.valid && !req.valid(q)) return false;
  r.solutions.push_back({q, ep, er});
  r.status = IkStatus::kSuccess;
  return true;
}

}  // namespace mm
