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

TEST(UrAnalyticIk, AChainOfAnotherShapeIsRefused) {
  const RobotModel panda = RobotModel::load("robots/panda/panda.yaml");
  EXPECT_THROW(UrAnalyticIk{panda}, InputError);
}

}  // namespace
}  // namespace mm
