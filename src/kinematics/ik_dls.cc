// Our numerical IK: Levenberg–Marquardt with damping tied to the error (Sugihara 2011,
// "Solvability-unconcerned inverse kinematics by the Levenberg–Marquardt method"), on FastChain's
// analytic Jacobian; joint limits by clamping; deterministic random restarts. The solver's working
// vectors are preallocated: a solve allocates only the solution it returns.
#include <Eigen/Dense>
#include <chrono>
#include <cmath>

#include "kinematics/chain.h"
#include "kinematics/ik_solvers.h"

namespace mm {

bool dlsDescend(const FastChain& chain, const VecX& lo, const VecX& hi, const Mat3& Rt, const Vec3& pt,
                const IkRequest& req, int max_iterations, VecX& q, long& iterations) {
  const int n = chain.dof();
  FastChain::Jac J;
  Mat3 R;
  Vec3 p;
  Eigen::Matrix<double, 6, 6> A;
  FastChain::Vec dq(n);
  double last = INFINITY;
  for (int it = 0; it < max_iterations; ++it) {
    ++iterations;
    chain.fkJacobian(q.data(), R, p, J);
    const Eigen::Matrix<double, 6, 1> e = poseError(Rt, pt, R, p);
    const double ep = e.head<3>().norm(), er = e.tail<3>().norm();
    if (ep < req.tol_position && er < req.tol_rotation) return true;
    const double E = e.squaredNorm();
    if (E > 0.999 * last && it > 8) return false;  // stalled (a local minimum or a limit)
    last = E;
    A.noalias() = J * J.transpose();
    A.diagonal().array() += E + 1e-9;
    dq.noalias() = J.transpose() * A.llt().solve(e);
    q = (q + dq).cwiseMax(lo).cwiseMin(hi);
  }
  return false;
}

namespace {

class DlsSolver final : public IkSolver {
 public:
  explicit DlsSolver(const RobotModel& robot)
      : robot_(robot), chain_(robot), lo_(robot.dof()), hi_(robot.dof()), q_(robot.dof()) {}
  std::string name() const override { return "dls"; }

  IkResult solve(const IkRequest& req, Rng& rng) override {
    IkResult r;
    if (!validRequest(robot_, req, r)) return r;
    const auto t0 = std::chrono::steady_clock::now();
    const int n = robot_.dof();
    VecX &lo = lo_, &hi = hi_, &q = q_;
    lo = robot_.lower().array() + req.limit_margin;
    hi = robot_.upper().array() - req.limit_margin;
    const Mat3 Rt = req.target.linear();
    const Vec3 pt = req.target.translation();
    while (r.attempts < req.max_attempts && r.iterations < req.max_iterations) {
      if (r.attempts == 0) q = req.seed.cwiseMax(lo).cwiseMin(hi);
      else
        for (int i = 0; i < n; ++i) q[i] = rng.uniform(lo[i], hi[i]);
      ++r.attempts;
      const long left = req.max_iterations - r.iterations;
      if (dlsDescend(chain_, lo, hi, Rt, pt, req, static_cast<int>(std::min<long>(left, 60)), q, r.iterations) &&
          addSolution(r, robot_, req, q) && static_cast<int>(r.solutions.size()) >= req.max_solutions)
        return r;
      if ((r.attempts & 7) == 0 &&
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > req.time_cap) {
        r.hit_time_cap = true;
        break;
      }
    }
    if (r.solutions.empty()) {
      r.status = IkStatus::kNoSolution;
      r.reason = "no solution in " + std::to_string(r.attempts) + " attempts, " + std::to_string(r.iterations) + " iterations";
    }
    return r;
  }

 private:
  const RobotModel& robot_;
  FastChain chain_;
  VecX lo_, hi_, q_;  // working storage, sized once
};

}  // namespace

std::unique_ptr<IkSolver> makeDlsSolver(const RobotModel& robot) { return std::make_unique<DlsSolver>(robot); }

void descendFromStarts(const RobotModel& robot, const FastChain& chain, const IkRequest& req,
                       const std::vector<VecX>& starts, Rng& rng, std::chrono::steady_clock::time_point t0, IkResult& r) {
  const VecX lo = robot.lower().array() + req.limit_margin, hi = robot.upper().array() - req.limit_margin;
  VecX q(robot.dof());
  for (size_t i = 0; r.attempts < req.max_attempts && r.iterations < req.max_iterations; ++i) {
    if (i < starts.size()) q = starts[i].cwiseMax(lo).cwiseMin(hi);
    else
      for (int j = 0; j < robot.dof(); ++j) q[j] = rng.uniform(lo[j], hi[j]);
    ++r.attempts;
    if (dlsDescend(chain, lo, hi, req.target.linear(), req.target.translation(), req, 60, q, r.iterations) &&
        addSolution(r, robot, req, q) && static_cast<int>(r.solutions.size()) >= req.max_solutions)
      return;
    if ((i & 7) == 7 && std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > req.time_cap) {
      r.hit_time_cap = true;
      return;
    }
  }
}

}  // namespace mm
