// The UR family's closed-form IK on the UR5e: every branch reproduces the pose, the configuration
// a pose came from is among the branches (up to whole turns), the nearest turn is taken, and a
// chain of another shape is refused.
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "kinematics/chain.h"
#include "kinematics/ik.h"
#include "kinematics/ik_solvers.h"
#include "kinematics/ur_analytic.h"

namespace mm {
namespace {

const RobotModel& ur5e() {
  static const RobotModel robot = RobotModel::load("robots/ur5e/ur5e.yaml");
  return robot;
}

double poseDistance(const Pose& a, const Pose& b) {
  const auto e = poseError(a.linear(), a.translation(), b.linear(), b.translation());
  return std::max(e.head<3>().norm(), e.tail<3>().norm());
}

double wrapDistance(double a, double b) { return std::abs(std::remainder(a - b, 2 * M_PI)); }

TEST(UrAnalyticIk, EveryBranchReproducesThePoseAndTheSourceConfigurationIsOneOfThem) {
  const RobotModel& robot = ur5e();
  const UrAnalyticIk ik(robot);
  Rng rng(7);
  std::array<UrAnalyticIk::Joints, 8> sols;
  int found = 0;
  const int kPoses = 2000;
  for (int t = 0; t < kPoses; ++t) {
    VecX q(6);
    for (int j = 0; j < 6; ++j) q[j] = rng.uniform(robot.lower()[j], robot.upper()[j]);
    const Pose T = robot.fk(q);
    const int n = ik.solve(T, q[5], sols);
    ASSERT_GT(n, 0) << "trial " << t;
    bool source = false;
    for (int i = 0; i < n; ++i) {
      EXPECT_LT(poseDistance(robot.fk(sols[i]), T), 1e-9) << "trial " << t << " branch " << i;
      double d = 0;
      for (int j = 0; j < 6; ++j) d = std::max(d, wrapDistance(sols[i][j], q[j]));
      source = source || d < 1e-6;
    }
    found += source;
  }
  EXPECT_EQ(found, kPoses);
}

TEST(UrAnalyticIk, TheSolverReturnsTheTurnNearestTheSeed) {
  const RobotModel& robot = ur5e();
  auto solver = makeIkSolver("auto", robot);
  EXPECT_EQ(solver->name(), "analytic");
  Rng rng(3);
  VecX q(6);
  q << 0.3, -1.2, 1.4, -1.7, -1.57, 5.5;  // wrist 3 past pi: its other turn is -0.78
  IkRequest req;
  req.target = robot.fk(q);
  req.seed = q + VecX::Constant(6, 0.01);
  const IkResult r = solver->solve(req, rng);
  ASSERT_TRUE(r.ok()) << r.reason;
  EXPECT_LT((r.q() - q).cwiseAbs().maxCoeff(), 1e-6);
  req.seed[5] = -0.7;
  const IkResult r2 = solver->solve(req, rng);
  ASSERT_TRUE(r2.ok());
  EXPECT_NEAR(r2.q()[5], 5.5 - 2 * M_PI, 1e-6);
}

// At the exact wrist singularity (q5 = 0: axes 4 and 6 in line) only q4 + q6 is fixed; with the
// elbow nearly stretched most splits put frame 4's origin out of the elbow's reach, so the solver
// must pick a split that reaches, whatever the seed's q6.
TEST(UrAnalyticIk, TheExactWristSingularityIsSolvedFromAnySeed) {
  const RobotModel& robot = ur5e();
  auto solver = makeIkSolver("analytic", robot);
  Rng rng(1);
  VecX q(6);
  q << 0.3, -1.0, 0.05, -0.6, 0.0, 1.0;
  IkRequest req;
  req.target = robot.fk(q);
  req.max_solutions = 8;
  for (const double seed6 : {1.0, 2.5, -2.0, 4.0}) {
    req.seed = VecX::Zero(6);
    req.seed[5] = seed6;
    const IkResult r = solver->solve(req, rng);
    ASSERT_TRUE(r.ok()) << "seed q6 " << seed6 << ": " << r.reason;
    bool source_branch = false;  // a solution on the source's shoulder branch (its split may differ)
    for (const auto& s : r.solutions) {
      EXPECT_LT(poseDistance(robot.fk(s.q), req.target), 1e-9);
      source_branch = source_branch || wrapDistance(s.q[0], q[0]) < 1e-6;
    }
    EXPECT_TRUE(source_branch) << "seed q6 " << seed6;
  }
}

TEST(UrAnalyticIk, AChainOfAnotherShapeIsRefused) {
  const RobotModel panda = RobotModel::load("robots/panda/panda.yaml");
  EXPECT_THROW(UrAnalyticIk{panda}, InputError);
}

}  // namespace
}  // namespace mm
