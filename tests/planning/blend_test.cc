// Blending a joint move into the next where it would stop (planning/blend.h): the overlap runs
// both at once within the limits, inside the blend radius, and only where valid; outside it the
// two motions are unchanged, and the whole is shorter by the overlap.
#include "planning/blend.h"

#include <gtest/gtest.h>

#include <cmath>

#include "planning/jerk.h"
#include "robot/robot_model.h"

namespace mm {
namespace {

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  return robot;
}

struct Moves {
  JointTrajectory a, b;
};

// A joint move to J, then one that lowers the TCP from there: both at 100% of the limits.
Moves moves() {
  const RobotModel& r = panda();
  VecX q0 = r.home(), J = r.home(), q2 = r.home();
  q0[0] -= 0.8;
  J[3] += 0.1;
  q2[1] += 0.12, q2[3] += 0.05;
  const LimitScaling full{1.0, 1.0};
  return {jerkLimitedTrajectory({q0, J}, r.vmax(), r.amax(), r.jmax(), full, 0.002),
          jerkLimitedTrajectory({J, q2}, r.vmax(), r.amax(), r.jmax(), full, 0.002)};
}

TEST(Blend, OverlapsWithinTheLimitsAndTheRadiusAndLeavesTheRestAlone) {
  const RobotModel& r = panda();
  const Moves m0 = moves();
  Moves m = m0;
  const Vec3 p_junction = r.fk(m0.a.q.col(m0.a.size() - 1)).translation();
  const int k = blendJunction(m.a, m.b, r, {0.02, {1.0, 1.0}}, [](const VecX&) { return true; });
  ASSERT_GT(k, 10) << "a real overlap";
  EXPECT_EQ(m.a.size(), m0.a.size() - k);
  EXPECT_EQ(m.b.size(), m0.b.size());
  EXPECT_NEAR(m.a.duration() + m.b.duration(), m0.a.duration() + m0.b.duration() - k * 0.002, 1e-12);
  // a is a prefix of itself, b's tail is b's, and b starts where a now ends (moving).
  EXPECT_TRUE(m.a.q.isApprox(m0.a.q.leftCols(m.a.size())));
  EXPECT_TRUE(m.b.q.rightCols(m.b.size() - k - 1).isApprox(m0.b.q.rightCols(m.b.size() - k - 1)));
  EXPECT_LT((m.b.q.col(0) - m.a.q.col(m.a.size() - 1)).norm(), 1e-12);
  EXPECT_GT(m.a.qd.col(m.a.size() - 1).norm(), 0.05) << "a ends moving: it hands on";
  // The joined motion: within the velocity and acceleration limits everywhere, no jump, and the
  // blended samples within 2 cm of the corner.
  JointTrajectory whole = m.a;
  whole.append(m.b);
  for (int i = 0; i < whole.size(); ++i) {
    for (int j = 0; j < r.dof(); ++j) {
      ASSERT_LE(std::abs(whole.qd(j, i)), r.vmax()[j] * (1 + 1e-6)) << "joint " << j << " sample " << i;
      ASSERT_LE(std::abs(whole.qdd(j, i)), r.amax()[j] * (1 + 1e-6)) << "joint " << j << " sample " << i;
      if (i > 0) {
        ASSERT_LE(std::abs(whole.q(j, i) - whole.q(j, i - 1)), r.vmax()[j] * 0.002 * 1.01);
      }
    }
  }
  for (int i = 0; i <= k; ++i) EXPECT_LE((r.fk(m.b.q.col(i)).translation() - p_junction).norm(), 0.02 + 1e-9);
  // A tighter radius blends less.
  Moves t = m0;
  const int k_small = blendJunction(t.a, t.b, r, {0.005, {1.0, 1.0}}, [](const VecX&) { return true; });
  EXPECT_LT(k_small, k);
}

TEST(Blend, NothingBlendsWhereTheBlendIsInvalidOrTheRadiusIsZero) {
  const RobotModel& r = panda();
  const Moves m0 = moves();
  Moves m = m0;
  EXPECT_EQ(blendJunction(m.a, m.b, r, {0.02, {1.0, 1.0}}, [](const VecX&) { return false; }), 0);
  EXPECT_TRUE(m.a.q.isApprox(m0.a.q));
  EXPECT_TRUE(m.b.q.isApprox(m0.b.q));
  EXPECT_EQ(blendJunction(m.a, m.b, r, {0.0, {1.0, 1.0}}, [](const VecX&) { return true; }), 0);
  EXPECT_EQ(m.a.size(), m0.a.size());
  // A validity that refuses the blend's outer part (say, an obstacle there) leaves a shorter overlap.
  const VecX J = m0.a.q.col(m0.a.size() - 1);
  const Vec3 pJ = r.fk(J).translation();
  const int k = blendJunction(m.a, m.b, r, {0.02, {1.0, 1.0}},
                              [&](const VecX& q) { return (r.fk(q).translation() - pJ).norm() < 0.01; });
  Moves all = m0;
  const int k_all = blendJunction(all.a, all.b, r, {0.02, {1.0, 1.0}}, [](const VecX&) { return true; });
  EXPECT_GT(k, 0);
  EXPECT_LT(k, k_all);
}

}  // namespace
}  // namespace mm
