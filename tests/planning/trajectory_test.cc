#include "planning/trajectory.h"

#include <gtest/gtest.h>

#include "core/rng.h"
#include "kinematics/ik.h"
#include "planning/cartesian.h"
#include "planning/jerk.h"

namespace mm {
namespace {

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  return robot;
}

// Every configuration is valid: these tests are about timing along a path, not about obstacles.
struct NoObstacles : CollisionChecker {
  bool isValid(const VecX&) override { return true; }
  std::string lastCollision() const override { return ""; }
};

// One DLS solve from the seed to 1e-10 m and 1e-9 rad, so that the joint path follows the line
// without IK tolerance showing up as jitter in the finite differences.
IkResult exactIk(IkSolver& solver, Rng& rng, const Pose& target, const VecX& seed) {
  IkRequest o;
  o.target = target;
  o.seed = seed;
  o.max_attempts = 1;
  o.tol_position = 1e-10;
  o.tol_rotation = 1e-9;
  return solver.solve(o, rng);
}

// 200 random multi-waypoint paths (seed 21), several limit scalings: every sample of every
// trajectory is within the position, velocity and acceleration limits, and it passes through
// each waypoint at rest.
TEST(TrapezoidalTrajectory, RespectsScaledLimitsAndHitsWaypoints) {
  const RobotModel& r = panda();
  Rng rng(21);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<VecX> wp;
    const int n = 2 + static_cast<int>(rng.below(4));
    for (int i = 0; i < n; ++i) {
      VecX q(r.dof());
      for (int j = 0; j < r.dof(); ++j) q[j] = rng.uniform(r.lower()[j], r.upper()[j]);
      wp.push_back(q);
    }
    const LimitScaling s{rng.uniform(0.1, 1.0), rng.uniform(0.1, 1.0)};
    const JointTrajectory t = trapezoidalTrajectory(wp, r.vmax(), r.amax(), s, 0.002);
    ASSERT_GT(t.size(), 1);
    EXPECT_LT((t.q.col(0) - wp.front()).norm(), 1e-12);
    EXPECT_LT((t.q.col(t.size() - 1) - wp.back()).norm(), 1e-12);
    EXPECT_LT(t.qd.col(t.size() - 1).norm(), 1e-12);
    const LimitReport rep = checkLimits(t, r, 1e-9);
    EXPECT_TRUE(rep.positions_ok) << rep.worst;
    EXPECT_LE(rep.max_velocity_ratio, s.velocity * (1 + 1e-9)) << "trial " << trial;
    EXPECT_LE(rep.max_acceleration_ratio, s.acceleration * (1 + 1e-9)) << "trial " << trial;
    // The analytic velocities integrate to the positions (the profile is consistent).
    for (int k = 1; k < t.size(); ++k) {
      const VecX mid = 0.5 * (t.qd.col(k) + t.qd.col(k - 1)) * t.dt;
      ASSERT_LT((t.q.col(k) - t.q.col(k - 1) - mid).cwiseAbs().maxCoeff(), 0.5 * r.amax().maxCoeff() * t.dt * t.dt + 1e-12);
    }
  }
}

TEST(TrapezoidalTrajectory, MinimumTimeForOneJoint) {
  // One joint moving 1 rad at v = 2.175 rad/s, a = 15 rad/s^2 (joint 1, unscaled):
  // accelerating to v takes v/a = 0.145 s over 0.1577 rad, so a trapezoid of 1/v + v/a = 0.6048 s.
  const RobotModel& r = panda();
  VecX a = r.home(), b = r.home();
  b[0] += 1.0;
  const JointTrajectory t = trapezoidalTrajectory({a, b}, r.vmax(), r.amax(), {1.0, 1.0}, 0.002);
  EXPECT_NEAR(t.duration(), 1.0 / 2.175 + 2.175 / 15.0, 0.002);
}

// Straight TCP lines sampled every 2 ms with IK: smooth enough that finite differences stay
// within the scaled limits, and the TCP stays on the line.
TEST(CartesianTrajectory, StraightLineWithinLimits) {
  const RobotModel& r = panda();
  NoObstacles checker_free;
  Rng rng(3);
  auto dls = makeIkSolver("dls", r);
  const IkFunction ik = [&](const Pose& T, const VecX& seed, VecX& q) {
    const IkResult res = exactIk(*dls, rng, T, seed);
    if (res.ok()) q = res.q();
    return res.ok();
  };
  const VecX q0 = r.home();
  Pose goal = r.fk(q0);
  goal.translation() += Vec3(0.1, -0.15, -0.2);
  CartesianOptions co;
  const CartesianPath path = planCartesianLine(r, checker_free, q0, goal, ik, co);
  ASSERT_TRUE(path.ok) << path.reason;
  const LimitScaling s{0.5, 0.5};
  const JointTrajectory t = cartesianTrajectory(r, path, ik, s, co, 0.002);
  ASSERT_FALSE(t.empty());
  const LimitReport rep = checkLimits(t, r, 0.0);
  EXPECT_LE(rep.max_velocity_ratio, 0.5);
  EXPECT_LE(rep.max_acceleration_ratio, 0.5);
  const Vec3 p0 = r.fk(q0).translation(), dir = (goal.translation() - p0).normalized();
  for (int k = 0; k < t.size(); k += 10) {
    const Vec3 p = r.fk(t.q.col(k)).translation() - p0;
    EXPECT_LT((p - p.dot(dir) * dir).norm(), 1e-6);  // on the line
  }
  EXPECT_LT((r.fk(t.q.col(t.size() - 1)).translation() - goal.translation()).norm(), 1e-6);
}

// An IK whose joint path jumps halfway along the line (as at a joint's limit or a branch switch):
// slowing down cannot mend the jump, so the parameterization gives up after one slower try
// instead of multiplying the samples by the same large factor again and again. (Clutter rounds
// had a worker sit here for minutes, growing to 0.9 GB.) A joint driven out of its range gives up
// at once.
TEST(CartesianTrajectory, GivesUpOnAJointPathThatJumps) {
  const RobotModel& r = panda();
  NoObstacles free;
  Rng rng(3);
  auto dls = makeIkSolver("dls", r);
  const VecX q0 = r.home();
  Pose goal = r.fk(q0);
  goal.translation() += Vec3(0.0, 0.0, -0.2);
  const double z_half = r.fk(q0).translation().z() - 0.1;
  long calls = 0;
  double offset = 0.01;
  const IkFunction ik = [&](const Pose& T, const VecX& seed, VecX& q) {
    ++calls;
    const IkResult res = exactIk(*dls, rng, T, seed);
    if (!res.ok()) return false;
    q = res.q();
    if (T.translation().z() < z_half) q[0] += offset;  // past halfway, joint 1 is off by `offset`
    return true;
  };
  CartesianOptions co;
  const CartesianPath path = planCartesianLine(r, free, q0, goal, ik, co);
  ASSERT_TRUE(path.ok) << path.reason;
  const LimitScaling s{0.5, 0.5};
  calls = 0;
  EXPECT_TRUE(cartesianTrajectory(r, path, ik, s, co, 0.002).empty());
  // The first try has about 0.7 s of samples (350), the slower one about 34 times as many; a
  // third would have 34 times more again (the code before this test took 123,055 calls).
  EXPECT_GT(calls, 1000);
  EXPECT_LT(calls, 30000) << "calls " << calls;

  offset = r.upper()[0] - q0[0] + 0.05;  // past halfway, joint 1 is beyond its upper limit
  calls = 0;
  EXPECT_TRUE(cartesianTrajectory(r, path, ik, s, co, 0.002).empty());
  EXPECT_LT(calls, 400) << "calls " << calls;  // one try, about 0.7 s of samples

  offset = 0.0;  // no jump: the same line is parameterized
  EXPECT_FALSE(cartesianTrajectory(r, path, ik, s, co, 0.002).empty());
}

}  // namespace
}  // namespace mm

namespace mm {
namespace {

// 200 random paths (seed 22): the jerk-limited parameterization stays within the scaled velocity,
// acceleration and jerk limits at every sample and passes through each waypoint at rest.
TEST(JerkLimitedTrajectory, RespectsVelocityAccelerationAndJerkLimits) {
  const RobotModel& r = panda();
  Rng rng(22);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<VecX> wp;
    const int n = 2 + static_cast<int>(rng.below(3));
    for (int i = 0; i < n; ++i) {
      VecX q(r.dof());
      for (int j = 0; j < r.dof(); ++j) q[j] = rng.uniform(r.lower()[j], r.upper()[j]);
      wp.push_back(q);
    }
    const LimitScaling s{rng.uniform(0.1, 1.0), rng.uniform(0.1, 1.0)};
    const JointTrajectory t = jerkLimitedTrajectory(wp, r.vmax(), r.amax(), r.jmax(), s, 0.002);
    const LimitReport rep = checkLimits(t, r, 1e-9);
    EXPECT_TRUE(rep.positions_ok);
    EXPECT_LE(rep.max_velocity_ratio, s.velocity * (1 + 1e-6)) << trial;
    EXPECT_LE(rep.max_acceleration_ratio, s.acceleration * (1 + 1e-6)) << trial;
    EXPECT_LE(rep.max_jerk_ratio, s.acceleration * (1 + 1e-6)) << trial;
    EXPECT_LT((t.q.col(t.size() - 1) - wp.back()).norm(), 1e-12);
    // Continuous acceleration: no step larger than the jerk limit allows in one period.
    for (int k = 1; k < t.size(); ++k)
      ASSERT_LE(((t.qdd.col(k) - t.qdd.col(k - 1)).cwiseAbs().array() / (r.jmax().array() * t.dt)).maxCoeff(), s.acceleration * (1 + 1e-6));
  }
}

TEST(JerkLimitedTrajectory, NoFasterThanTheTrapezoid) {
  const RobotModel& r = panda();
  VecX a = r.home(), b = r.home();
  b[0] += 1.0, b[3] += 0.5;
  const LimitScaling s{0.5, 0.5};
  const double tr = trapezoidalTrajectory({a, b}, r.vmax(), r.amax(), s, 0.002).duration();
  const double jl = jerkLimitedTrajectory({a, b}, r.vmax(), r.amax(), r.jmax(), s, 0.002).duration();
  EXPECT_GE(jl, tr - 1e-9);
  EXPECT_LT(jl, tr + 0.05);  // the Panda's jerk limits are 500x its acceleration limits: phases of ~2 ms
}

}  // namespace
}  // namespace mm

#include "planning/totg.h"

namespace mm {
namespace {

// 200 random paths of 2-6 waypoints inside the joint range (seed 23), random scalings: TOTG's
// samples stay within the scaled velocity and acceleration limits (analytic values and finite
// differences alike), pass within max_deviation of every waypoint and end exactly at the last one.
// And it is not slower than stopping at every waypoint (trapezoidal, the same limits) by more than
// 1.5% on any path (where discretization oversteps a limit, only the segments concerned are
// tightened; on sharp corners the blend is nearly a stop, and the grid integration loses a little
// against the trapezoid's exact switching times: 1.2% at worst here).
TEST(Totg, WithinLimitsAndNearTheWaypoints) {
  const RobotModel& r = panda();
  Rng rng(23);
  TotgOptions o;
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<VecX> wp;
    const int n = 2 + static_cast<int>(rng.below(5));
    for (int i = 0; i < n; ++i) {
      VecX q(r.dof());
      for (int j = 0; j < r.dof(); ++j) q[j] = rng.uniform(r.lower()[j] + 0.1, r.upper()[j] - 0.1);
      wp.push_back(q);
    }
    const LimitScaling s{rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.0)};
    const JointTrajectory t = totgTrajectory(wp, r, s, 0.002, o);
    ASSERT_FALSE(t.empty()) << "trial " << trial;
    JointTrajectory fd = t;
    differentiate(fd);
    for (const JointTrajectory* x : {&t, static_cast<const JointTrajectory*>(&fd)}) {
      const LimitReport rep = checkLimits(*x, r, 0.0);
      EXPECT_TRUE(rep.positions_ok) << trial;
      EXPECT_LE(rep.max_velocity_ratio, s.velocity * (1 + 1e-6)) << trial;
      EXPECT_LE(rep.max_acceleration_ratio, s.acceleration * (1 + 1e-6)) << trial;
    }
    EXPECT_LT((t.q.col(t.size() - 1) - wp.back()).norm(), 1e-9);
    const double stop = trapezoidalTrajectory(wp, r.vmax(), r.amax(), s, 0.002).duration();
    EXPECT_LE(t.duration(), 1.015 * stop) << trial;
    for (size_t i = 1; i + 1 < wp.size(); ++i) {
      double nearest = INFINITY;
      for (int k = 0; k < t.size(); ++k) nearest = std::min(nearest, (t.q.col(k) - wp[i]).norm());
      EXPECT_LE(nearest, o.max_deviation + 0.01) << "trial " << trial << " waypoint " << i;
    }
  }
}

// A dense path along a gentle curve (12 waypoints on a quarter circle through joints 1 and 2):
// stopping at every waypoint wastes most of the time, blending through them does not.
TEST(Totg, BlendsThroughGentleCornersMuchFasterThanStopping) {
  const RobotModel& r = panda();
  std::vector<VecX> wp;
  for (int k = 0; k < 12; ++k) {
    VecX q = r.home();
    const double phi = 0.5 * M_PI * k / 11;
    q[0] = std::cos(phi) - 1.0;
    q[1] = -0.785 + std::sin(phi);
    wp.push_back(q);
  }
  const LimitScaling s{0.5, 0.5};
  const JointTrajectory t = totgTrajectory(wp, r, s, 0.002);
  ASSERT_FALSE(t.empty());
  const double stop = trapezoidalTrajectory(wp, r.vmax(), r.amax(), s, 0.002).duration();
  EXPECT_LT(t.duration(), 0.6 * stop) << "totg " << t.duration() << " s, stopping " << stop << " s";
}

TEST(Totg, StraightLineIsTheTimeOptimalTrapezoid) {
  const RobotModel& r = panda();
  VecX a = r.home(), b = r.home();
  b[0] += 1.0, b[3] += 0.5, b[5] -= 0.3;
  const LimitScaling s{0.5, 0.5};
  EXPECT_NEAR(totgTrajectory({a, b}, r, s, 0.002).duration(),
              trapezoidalTrajectory({a, b}, r.vmax(), r.amax(), s, 0.002).duration(), 0.002 + 1e-9);
}

}  // namespace
}  // namespace mm
