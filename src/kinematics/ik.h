// Inverse kinematics behind one interface. A solve never throws and never hangs: failures are
// values (status + reason). Each solver is deterministic for a given request (seed configuration,
// budgets) and RNG stream; the wall-clock cap is only a safety net, and hitting it is reported.
#pragma once
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/pose.h"
#include "core/rng.h"
#include "robot/robot_model.h"

namespace mm {

enum class IkStatus { kSuccess, kNoSolution, kInvalidInput };

struct IkRequest {
  Pose target = Pose::Identity();  ///< T_base_tcp
  VecX seed;                       ///< start configuration [rad], dim dof
  long max_iterations = 20000;     ///< budget in work units (one FK+Jacobian evaluation, one q7 sample)
  int max_attempts = 1000;         ///< seed + random restarts
  double time_cap = 0.05;          ///< [s] wall-clock safety cap
  double tol_position = 1e-5;      ///< [m]
  double tol_rotation = 1e-5;      ///< [rad]
  double limit_margin = 0.0;       ///< solutions keep this far inside the joint limits [rad]
  int max_solutions = 1;           ///< stop once this many distinct solutions are found
  double distinct = 0.1;           ///< [rad] solutions closer than this (max-norm) count as one
  /// Return the solution nearest the seed (Euclidean in joint space) rather than the first found:
  /// what motion planning wants, at some extra cost (the analytic solver sweeps q7 and refines).
  bool nearest = false;
  /// Whether a solution is acceptable beyond the limits and the tolerances (free of collision, say:
  /// MoveIt's GroupStateValidityCallbackFn); none: every one is. A solution it refuses is passed
  /// over as one outside the limits is (the nearest then is the nearest it accepts), and none is
  /// returned unless it accepts one. Called from the solve's own thread only.
  std::function<bool(const VecX&)> valid;
};

struct IkSolution {
  VecX q;
  double position_error = 0;  ///< [m]
  double rotation_error = 0;  ///< [rad]
};

struct IkResult {
  IkStatus status = IkStatus::kNoSolution;
  std::string reason;
  std::vector<IkSolution> solutions;  ///< distinct, in the order found (the first is "the" answer)
  long iterations = 0;                ///< work units spent
  int attempts = 0;
  int threads = 1;
  bool hit_time_cap = false;
  bool ok() const { return status == IkStatus::kSuccess; }
  const VecX& q() const { return solutions.front().q; }
};

class IkSolver {
 public:
  virtual ~IkSolver() = default;
  virtual std::string name() const = 0;
  virtual int threads() const { return 1; }
  virtual IkResult solve(const IkRequest& request, Rng& rng) = 0;
};

/// Solver names, fastest-reliable first: "auto" (the robot's closed form when its YAML declares
/// one, else dls), "analytic" (the declared closed form: He & Liu's geometric Panda IK sweeping
/// q7 from the seed's, or the UR family's 8-branch solution), "dls" (ours: Levenberg–Marquardt on our analytic Jacobian, restarts),
/// "hybrid" (dls seeded by the analytic solver), "kdl" (orocos-KDL ChainIkSolverPos_NR_JL, one
/// attempt from the seed, as MoveIt's default plugin), "kdl_restarts", "trac_ik" (the TRAC-IK
/// method, Speed mode: Newton with restarts and SQP by NLopt in two threads), "trac_ik_distance".
std::vector<std::string> ikSolverNames();
/// Throws InputError for an unknown name or a robot the solver cannot handle.
std::unique_ptr<IkSolver> makeIkSolver(const std::string& name, const RobotModel& robot);

/// The solution of `result` closest (max-norm) to `reference`, or -1 if there is none.
int closestSolution(const IkResult& result, const VecX& reference);

/// Builds a result's common fields: checks a candidate (limits with margin, errors within
/// tolerance, the request's validity) and adds it when distinct. Returns true when it was added.
bool addSolution(IkResult& result, const RobotModel& robot, const IkRequest& request, const VecX& q);
/// Input checks shared by the solvers; fills `result` and returns false on bad input.
bool validRequest(const RobotModel& robot, const IkRequest& request, IkResult& result);

}  // namespace mm
