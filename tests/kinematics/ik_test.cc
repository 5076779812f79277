// IK solvers: round trips, limits, clean failures, the analytic solutions, KDL against our FK.
#include "kinematics/ik.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "kinematics/chain.h"
#include "kinematics/ik_solvers.h"
#include "kinematics/panda_analytic.h"
#include "core/error.h"

namespace mm {
namespace {

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  return robot;
}

VecX randomConfig(Rng& rng) {
  VecX q(7);
  for (int j = 0; j < 7; ++j) q[j] = rng.uniform(panda().lower()[j], panda().upper()[j]);
  return q;
}

VecX midRange() { return 0.5 * (panda().lower() + panda().upper()); }

double poseDistance(const Pose& a, const Pose& b) {
  const auto e = poseError(a.linear(), a.translation(), b.linear(), b.translation());
  return std::max(e.head<3>().norm(), e.tail<3>().norm());
}

class EverySolver : public ::testing::TestWithParam<std::string> {};

// 60 reachable poses (FK of random configurations, seed 31), mid-range seed: every solution a
// solver returns reproduces the target within the tolerance and respects the limits and margin.
TEST_P(EverySolver, SolutionsReproduceTheTargetWithinLimits) {
  auto solver = makeIkSolver(GetParam(), panda());
  Rng poses(31), rng(5);
  int ok = 0;
  for (int i = 0; i < 60; ++i) {
    IkRequest req;
    req.target = panda().fk(randomConfig(poses));
    req.seed = midRange();
    req.limit_margin = 0.02;
    req.time_cap = 1.0;  // generous: correctness, not speed
    if (GetParam() == "trac_ik_distance") req.max_iterations = 400;  // it spends its whole budget
    const IkResult r = solver->solve(req, rng);
    if (!r.ok()) {
      EXPECT_FALSE(r.reason.empty());
      continue;
    }
    ++ok;
    for (const auto& s : r.solutions) {
      EXPECT_LT((panda().fk(s.q).translation() - req.target.translation()).norm(), 1e-5);
      EXPECT_LT(poseDistance(panda().fk(s.q), req.target), 1e-5);
      EXPECT_TRUE(panda().withinLimits(s.q, 0.02 - 1e-9)) << s.q.transpose();
    }
  }
  // The single-attempt KDL baseline is expected to fail often (about half); the others not.
  EXPECT_GE(ok, GetParam() == "kdl" ? 15 : GetParam() == "kdl_restarts" ? 40 : 59) << GetParam();
}

// The request's validity check (MoveIt's state validity callback: in a trial, free of collision):
// every solution returned passes it, and a check that refuses everything leaves no solution and a
// reason. 20 poses (seed 37); the check asks for q7 above its mid-range.
TEST_P(EverySolver, EverySolutionPassesTheValidityCheckOrNoneIsReturned) {
  auto solver = makeIkSolver(GetParam(), panda());
  Rng poses(37), rng(6);
  const double mid7 = 0.5 * (panda().lower()[6] + panda().upper()[6]);
  int ok = 0, calls = 0;
  for (int i = 0; i < 20; ++i) {
    IkRequest req;
    req.target = panda().fk(randomConfig(poses));
    req.seed = midRange();
    req.time_cap = 1.0;
    if (GetParam() == "trac_ik_distance") req.max_iterations = 400;
    req.valid = [&](const VecX& q) {
      ++calls;
      return q[6] > mid7;
    };
    const IkResult r = solver->solve(req, rng);
    if (r.ok()) {
      ++ok;
      for (const auto& s : r.solutions) EXPECT_GT(s.q[6], mid7) << GetParam() << ", pose " << i;
    } else {
      EXPECT_FALSE(r.reason.empty());
    }
    IkRequest never = req;
    never.valid = [](const VecX&) { return false; };
    const IkResult none = solver->solve(never, rng);
    EXPECT_FALSE(none.ok()) << GetParam() << ", pose " << i;
    EXPECT_TRUE(none.solutions.empty());
    EXPECT_FALSE(none.reason.empty());
  }
  EXPECT_GT(calls, 0);
  // The closed forms sweep q7 itself: they find that half wherever the other joints' limits leave
  // it room (16 of the 20 poses).
  if (GetParam() == "analytic" || GetParam() == "hybrid") {
    EXPECT_GE(ok, 15);
  }
}

TEST_P(EverySolver, UnreachableAndNanFailCleanly) {
  auto solver = makeIkSolver(GetParam(), panda());
  Rng rng(1);
  IkRequest req;
  req.seed = midRange();
  req.max_iterations = 4000;
  req.time_cap = 1.0;
  req.target = makePose(Vec3(2.0, 0.0, 0.5), Mat3::Identity());  // 2 m away: beyond the 0.86 m reach
  const IkResult far = solver->solve(req, rng);
  EXPECT_EQ(far.status, IkStatus::kNoSolution);
  EXPECT_FALSE(far.reason.empty());
  EXPECT_LE(far.iterations, 4000 + 200);  // bounded by the budget (plus one attempt's overrun)
  req.target.translation().x() = std::nan("");
  const IkResult nan = solver->solve(req, rng);
  EXPECT_EQ(nan.status, IkStatus::kInvalidInput);
  EXPECT_EQ(nan.iterations, 0);
  req.target = panda().fk(panda().home());
  req.seed = VecX::Zero(3);
  EXPECT_EQ(solver->solve(req, rng).status, IkStatus::kInvalidInput);
}

TEST_P(EverySolver, DeterministicForTheSameStream) {
  auto a = makeIkSolver(GetParam(), panda()), b = makeIkSolver(GetParam(), panda());
  Rng poses(8), ra(99), rb(99);
  for (int i = 0; i < 15; ++i) {
    IkRequest req;
    req.target = panda().fk(randomConfig(poses));
    req.seed = midRange();
    req.time_cap = 10.0;  // never reached: the iteration budget decides
    req.max_iterations = GetParam() == "trac_ik_distance" ? 400 : 20000;
    const IkResult x = a->solve(req, ra), y = b->solve(req, rb);
    ASSERT_EQ(x.ok(), y.ok()) << "pose " << i;
    if (x.ok()) {
      EXPECT_EQ(x.q(), y.q()) << "pose " << i;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Ik, EverySolver, ::testing::ValuesIn(ikSolverNames()));

// For several q7 values over 40 random targets (seed 17), every solution the analytic solver
// returns reproduces the target to 1e-9, and the target's own configuration is among them.
TEST(PandaAnalyticIk, EverySolutionReproducesTheTarget) {
  const PandaAnalyticIk ik(panda());
  Rng rng(17);
  std::array<PandaAnalyticIk::Joints, 16> sols;
  int found_original = 0;
  for (int i = 0; i < 40; ++i) {
    const VecX q = randomConfig(rng);
    const Pose T = panda().fk(q);
    const int n = ik.solve(T, q[6], q[0], sols);
    ASSERT_GE(n, 1);
    for (int k = 0; k < n; ++k) {
      EXPECT_LT(poseDistance(panda().fk(sols[k]), T), 1e-9);
      if ((VecX(sols[k]) - q).cwiseAbs().maxCoeff() < 1e-8) ++found_original;
    }
    for (double q7 : {-1.0, 0.0, 1.5}) {
      const int m = ik.solve(T, q7, q[0], sols);
      for (int k = 0; k < m; ++k) EXPECT_LT(poseDistance(panda().fk(sols[k]), T), 1e-9);
    }
  }
  EXPECT_EQ(found_original, 40);
}

TEST(IkSolvers, SeveralDistinctSolutionsAndTheClosestToAReference) {
  auto solver = makeIkSolver("analytic", panda());
  Rng rng(3);
  IkRequest req;
  req.target = panda().fk(panda().home());
  req.seed = panda().home();
  req.max_solutions = 8;
  const IkResult r = solver->solve(req, rng);
  ASSERT_TRUE(r.ok());
  EXPECT_GE(r.solutions.size(), 4u);
  for (size_t i = 0; i < r.solutions.size(); ++i)
    for (size_t j = i + 1; j < r.solutions.size(); ++j)
      EXPECT_GE((r.solutions[i].q - r.solutions[j].q).cwiseAbs().maxCoeff(), req.distinct);
  const int c = closestSolution(r, panda().home());
  ASSERT_GE(c, 0);
  for (const auto& s : r.solutions)
    EXPECT_LE((r.solutions[c].q - panda().home()).cwiseAbs().maxCoeff(), (s.q - panda().home()).cwiseAbs().maxCoeff());
  EXPECT_LT((r.solutions[c].q - panda().home()).cwiseAbs().maxCoeff(), 1e-6);  // home itself
}

TEST(IkSolvers, KdlChainAgreesWithOurForwardKinematics) {  // 100 random configurations, seed 4
  Rng rng(4);
  const FastChain chain(panda());
  for (int i = 0; i < 100; ++i) {
    const VecX q = randomConfig(rng);
    const Pose ours = panda().fk(q), kdl = kdlForwardKinematics(panda(), q);
    EXPECT_LT((ours.matrix() - kdl.matrix()).cwiseAbs().maxCoeff(), 1e-12);
    Mat3 R;
    Vec3 p;
    chain.fk(q.data(), R, p);
    EXPECT_LT((p - ours.translation()).norm(), 1e-12);
    EXPECT_LT((R - ours.linear()).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(IkSolvers, UnknownSolverIsAnInputError) {
  EXPECT_THROW(makeIkSolver("ikfast", panda()), InputError);
}

}  // namespace
}  // namespace mm

namespace mm {
namespace {

// Nearest mode: for a target made from configuration q and a seed within 0.05 rad of q, the answer
// is at least as near the seed as q itself (q being one valid answer), so on q's branch.
// 40 random configurations, seed 23, analytic solver.
TEST(IkSolvers, NearestModeReturnsTheBranchOfTheSeed) {
  auto solver = makeIkSolver("analytic", panda());
  Rng rng(23), noise(24);
  for (int i = 0; i < 40; ++i) {
    VecX q = randomConfig(rng);
    for (int j = 0; j < 7; ++j) q[j] = std::clamp(q[j], panda().lower()[j] + 0.06, panda().upper()[j] - 0.06);
    IkRequest req;
    req.target = panda().fk(q);
    req.seed = q;
    for (int j = 0; j < 7; ++j) req.seed[j] += noise.uniform(-0.05, 0.05);
    req.nearest = true;
    const IkResult r = solver->solve(req, noise);
    ASSERT_TRUE(r.ok()) << r.reason;
    // q7 is sampled down to 1.4e-4 rad; joints may move ~20x faster along the self-motion manifold.
    EXPECT_LE((r.q() - req.seed).norm(), (q - req.seed).norm() + 3e-3) << "configuration " << i;
    EXPECT_LT((r.q() - q).cwiseAbs().maxCoeff(), 0.3) << "configuration " << i;
  }
}

// Nearest mode with a validity check: the nearest solution the check accepts. Refusing the
// unchecked answer's neighbourhood gives another, as near as the rest allow, that it accepts.
TEST(IkSolvers, NearestModeReturnsTheNearestSolutionTheCheckAccepts) {
  auto solver = makeIkSolver("analytic", panda());
  Rng rng(41);
  int moved = 0;
  for (int i = 0; i < 20; ++i) {
    IkRequest req;
    req.target = panda().fk(randomConfig(rng));
    req.seed = panda().home();
    req.nearest = true;
    const IkResult free = solver->solve(req, rng);
    if (!free.ok()) continue;
    const VecX q0 = free.q();
    req.valid = [&](const VecX& q) { return (q - q0).cwiseAbs().maxCoeff() > 0.3; };
    const IkResult other = solver->solve(req, rng);
    if (!other.ok()) {
      EXPECT_THAT(other.reason, testing::HasSubstr("valid"));
      continue;
    }
    ++moved;
    EXPECT_GT((other.q() - q0).cwiseAbs().maxCoeff(), 0.3) << "pose " << i;
    EXPECT_GE((other.q() - req.seed).norm(), (q0 - req.seed).norm() - 1e-9) << "pose " << i;
    EXPECT_LT(poseDistance(panda().fk(other.q()), req.target), 1e-5);
  }
  EXPECT_GE(moved, 10);
}

}  // namespace
}  // namespace mm
