#include "planning/jerk.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/rng.h"

namespace mm {
namespace {

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  return robot;
}

// Checks one joint's profile: it lasts T, ends at (pf, vf, af), and stays within V, A, J.
void expectProfile(const JerkProfile& p, double pf, double vf, double af, double V, double A, double J, double T,
                   const std::string& what) {
  EXPECT_NEAR(p.totalDuration(), T, 1e-9 * std::max(1.0, T)) << what;
  double x, v, a;
  p.eval(p.totalDuration(), x, v, a);
  EXPECT_NEAR(x, pf, 1e-8) << what;
  EXPECT_NEAR(v, vf, 1e-8) << what;
  EXPECT_NEAR(a, af, 1e-6 * A) << what;
  for (int k = 0; k < p.phases; ++k) EXPECT_LE(std::abs(p.jerk[k]), J * (1 + 1e-12)) << what;
  for (int i = 0; i <= 400; ++i) {
    p.eval(T * i / 400, x, v, a);
    ASSERT_LE(std::abs(v), V * (1 + 1e-9)) << what << " t=" << T * i / 400;
    ASSERT_LE(std::abs(a), A * (1 + 1e-9)) << what << " t=" << T * i / 400;
  }
}

// Closed forms: rest to rest with a cruise (double-S), a pure change of velocity, cruising
// between equal velocities, and a triangular profile that reaches neither V nor A.
TEST(JerkProfile, MinimumTimeMatchesClosedForms) {
  // Rest to rest, d = 2, V = 2, A = 5, J = 50: Tj = A/J = 0.1, Ta = Tj + V/A = 0.5, Tv = d/V - Ta = 0.5.
  EXPECT_NEAR(jerkMinTime(2, 0, 0, 2, 5, 50), 1.5, 1e-9);
  EXPECT_NEAR(jerkMinTime(-2, 0, 0, 2, 5, 50), 1.5, 1e-9);
  // 0 -> 1 rad/s: T = dv/A + A/J = 0.3 over d = 0.15.
  EXPECT_NEAR(jerkMinTime(0.15, 0, 1, 2, 5, 50), 0.3, 1e-9);
  // Already at V = 1, d = 3: cruise for 3 s.
  EXPECT_NEAR(jerkMinTime(3, 1, 1, 1, 5, 50), 3.0, 1e-9);
  // Rest to rest, short: jerk phases only, T = 4 (d / (2J))^(1/3).
  EXPECT_NEAR(jerkMinTime(0.002, 0, 0, 2, 5, 50), 4 * std::cbrt(0.002 / 100), 1e-9);
  // Nothing to do.
  EXPECT_NEAR(jerkMinTime(0, 0.5, 0.5, 1, 5, 50), 0.0, 1e-12);
}

// The rest-to-rest minimum time agrees with the independent double-S closed form
// (jerkLimitedTrajectory for one joint on a fine clock), over random limits and distances.
TEST(JerkProfile, RestToRestAgreesWithTheDoubleS) {
  Rng rng(41);
  for (int trial = 0; trial < 300; ++trial) {
    const double V = rng.uniform(0.2, 3), A = rng.uniform(0.5, 20), J = rng.uniform(5, 2000), d = rng.uniform(-3, 3);
    VecX v(1), a(1), j(1);
    v << V, a << A, j << J;
    VecX p0 = VecX::Zero(1), p1 = VecX::Constant(1, d);
    const double dt = 1e-5;
    const double ds = jerkLimitedTrajectory({p0, p1}, v, a, j, {1, 1}, dt).duration();
    EXPECT_NEAR(jerkMinTime(d, 0, 0, V, A, J), ds, dt + 1e-9) << trial;
  }
}

// Random boundary states and limits (seed 42): the minimum-time profile exists at Tmin, reaches
// its target within the limits; longer durations are met too (apart from the rare durations a
// joint cannot take); and no profile is found below Tmin, the two solvers agree.
TEST(JerkProfile, ProfilesOfPrescribedDurationReachTheTargetWithinLimits) {
  Rng rng(42);
  int longer = 0, longer_found = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const double V = rng.uniform(0.5, 2.5), A = rng.uniform(1, 15), J = rng.uniform(10, 1000);
    const double v0 = rng.uniform(-V, V) * (rng.below(4) == 0 ? 0 : 1), vf = rng.uniform(-V, V) * (rng.below(4) == 0 ? 0 : 1);
    const double p0 = rng.uniform(-1, 1), d = rng.uniform(-2, 2);
    const double Tmin = jerkMinTime(d, v0, vf, V, A, J);
    ASSERT_TRUE(std::isfinite(Tmin)) << trial;
    const std::string what = "trial " + std::to_string(trial);
    JerkProfile p;
    ASSERT_TRUE(jerkProfileForDuration(p0, p0 + d, v0, vf, V, A, J, Tmin * (1 + 1e-9) + 1e-12, p)) << what << " Tmin " << Tmin;
    expectProfile(p, p0 + d, vf, 0, V, A, J, Tmin * (1 + 1e-9) + 1e-12, what);
    if (Tmin > 1e-3) {
      EXPECT_FALSE(jerkProfileForDuration(p0, p0 + d, v0, vf, V, A, J, Tmin * (1 - 1e-4), p)) << what;
    }
    for (double k : {1.05, 1.5, 3.0}) {
      ++longer;
      if (jerkProfileForDuration(p0, p0 + d, v0, vf, V, A, J, Tmin * k + 0.01, p)) {
        ++longer_found;
        expectProfile(p, p0 + d, vf, 0, V, A, J, Tmin * k + 0.01, what + " x" + std::to_string(k));
      }
    }
  }
  // Blocked durations exist (e.g. moving fast, a short distance, then long: it must turn back
  // twice), but they are rare.
  EXPECT_GE(longer_found, 0.95 * longer);
}

// The same with accelerations at both ends (feasible states: |a| <= A, |v| + a^2 / 2J <= V), and
// the limits of the Panda's kind (J / A of 100 to 1000), seed 45.
TEST(JerkProfile, NonzeroEndAccelerations) {
  Rng rng(45);
  int longer = 0, longer_found = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const double V = rng.uniform(0.5, 2.5), A = rng.uniform(1, 15), J = A * rng.uniform(2, 1000);
    auto state = [&](double& v, double& a) {
      a = rng.uniform(-A, A);
      const double room = V - a * a / (2 * J);
      if (room > 0) {
        v = rng.uniform(-room, room);
      } else {
        v = 0, a = 0;
      }
    };
    double v0, a0, vf, af;
    state(v0, a0), state(vf, af);
    const double p0 = rng.uniform(-1, 1), d = rng.uniform(-2, 2);
    const double Tmin = jerkMinTime(d, v0, a0, vf, af, V, A, J);
    ASSERT_TRUE(std::isfinite(Tmin)) << trial;
    const std::string what = "trial " + std::to_string(trial);
    JerkProfile p;
    const double T = Tmin * (1 + 1e-9) + 1e-12;
    ASSERT_TRUE(jerkProfileForDuration(p0, p0 + d, v0, a0, vf, af, V, A, J, T, p)) << what << " Tmin " << Tmin;
    expectProfile(p, p0 + d, vf, af, V, A, J, T, what);
    if (Tmin > 1e-3) {
      EXPECT_FALSE(jerkProfileForDuration(p0, p0 + d, v0, a0, vf, af, V, A, J, Tmin * (1 - 1e-4), p)) << what;
    }
    for (double k : {1.05, 1.5, 3.0}) {
      ++longer;
      if (jerkProfileForDuration(p0, p0 + d, v0, a0, vf, af, V, A, J, Tmin * k + 0.01, p)) {
        ++longer_found;
        expectProfile(p, p0 + d, vf, af, V, A, J, Tmin * k + 0.01, what + " x" + std::to_string(k));
      }
    }
  }
  EXPECT_GE(longer_found, 0.95 * longer);
  // An infeasible state is refused, not approximated.
  EXPECT_FALSE(std::isfinite(jerkMinTime(1, 1.0, 2.0, 0, 0, 1.0, 5, 50)));
}

double distanceToPolyline(const VecX& q, const std::vector<VecX>& wp) {
  double best = INFINITY;
  for (size_t i = 0; i + 1 < wp.size(); ++i) {
    const VecX d = wp[i + 1] - wp[i];
    const double t = std::clamp((q - wp[i]).dot(d) / d.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (q - wp[i] - t * d).norm());
  }
  return best;
}

std::vector<VecX> randomPath(const RobotModel& r, Rng& rng, int n) {
  std::vector<VecX> wp;
  for (int i = 0; i < n; ++i) {
    VecX q(r.dof());
    for (int j = 0; j < r.dof(); ++j) q[j] = rng.uniform(r.lower()[j] + 0.3, r.upper()[j] - 0.3);
    wp.push_back(q);
  }
  return wp;
}

// 200 random Panda paths of 2-6 waypoints (seed 43), random scalings: every sample within the
// scaled velocity, acceleration and jerk limits, every waypoint hit exactly at its sample, rest at
// both ends, and never slower than resting at each waypoint (up to the rounding to periods).
TEST(JerkThroughWaypoints, WithinLimitsThroughEveryWaypoint) {
  const RobotModel& r = panda();
  Rng rng(43);
  double through = 0, stop = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const std::vector<VecX> wp = randomPath(r, rng, 2 + static_cast<int>(rng.below(5)));
    const LimitScaling s{rng.uniform(0.1, 1.0), rng.uniform(0.1, 1.0)};
    const JerkWaypointResult res = jerkLimitedThroughWaypoints(wp, r.vmax(), r.amax(), r.jmax(), s, 0.002);
    const JointTrajectory& t = res.trajectory;
    ASSERT_FALSE(t.empty());
    ASSERT_EQ(res.waypoint_samples.size(), wp.size());
    for (size_t i = 0; i < wp.size(); ++i) EXPECT_LT((t.q.col(res.waypoint_samples[i]) - wp[i]).norm(), 1e-12);
    EXPECT_EQ(res.waypoint_samples.back(), t.size() - 1);
    EXPECT_TRUE(t.qd.col(0).isZero(0) && t.qd.col(t.size() - 1).isZero(0));
    const LimitReport rep = checkLimits(t, r, 1e-9);
    EXPECT_LE(rep.max_velocity_ratio, s.velocity * (1 + 1e-6)) << trial;
    EXPECT_LE(rep.max_acceleration_ratio, s.acceleration * (1 + 1e-6)) << trial;
    EXPECT_LE(rep.max_jerk_ratio, s.acceleration * (1 + 1e-6)) << trial;
    // Consistent samples: positions integrate the velocities (trapezoid rule, O(dt^2)).
    for (int k = 1; k < t.size(); ++k)
      ASSERT_LT((t.q.col(k) - t.q.col(k - 1) - 0.5 * t.dt * (t.qd.col(k) + t.qd.col(k - 1))).cwiseAbs().maxCoeff(), 1e-5) << trial << " " << k;
    const double rest = jerkLimitedTrajectory(wp, r.vmax(), r.amax(), r.jmax(), s, 0.002).duration();
    EXPECT_LE(t.duration(), rest + 0.002 * 3 * (wp.size() - 1) + 1e-9) << trial;
    through += t.duration(), stop += rest;
  }
  EXPECT_LT(through, stop);
}

// Gentle corners (12 waypoints on a circle in two joints): passing through them at speed is much
// faster than stopping at each.
TEST(JerkThroughWaypoints, GentleCornersMuchFasterThanStopping) {
  const RobotModel& r = panda();
  std::vector<VecX> wp;
  for (int i = 0; i <= 12; ++i) {
    VecX q = r.home();
    q[0] += 0.8 * std::sin(M_PI * i / 12), q[3] += 0.8 * (1 - std::cos(M_PI * i / 12));
    wp.push_back(q);
  }
  const LimitScaling s{0.5, 0.5};
  const JerkWaypointResult res = jerkLimitedThroughWaypoints(wp, r.vmax(), r.amax(), r.jmax(), s, 0.002);
  const double rest = jerkLimitedTrajectory(wp, r.vmax(), r.amax(), r.jmax(), s, 0.002).duration();
  EXPECT_EQ(res.stops, 0);
  EXPECT_LT(res.trajectory.duration(), 0.6 * rest) << res.trajectory.duration() << " vs " << rest;
}

// The motion leaves the straight segments; the validity callback bounds it. Here: states farther
// than 0.02 rad from the path are invalid. Every sample of the result is valid; with nothing off
// the path allowed, it rests at every waypoint and equals the stop-at-waypoints trajectory.
TEST(JerkThroughWaypoints, ShrinksSpeedsUntilEverySampleIsValid) {
  const RobotModel& r = panda();
  Rng rng(44);
  int shrinks = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const std::vector<VecX> wp = randomPath(r, rng, 3 + static_cast<int>(rng.below(3)));
    const LimitScaling s{0.5, 0.5};
    auto near = [&](const VecX& q) { return distanceToPolyline(q, wp) < 0.02; };
    const JerkWaypointResult res = jerkLimitedThroughWaypoints(wp, r.vmax(), r.amax(), r.jmax(), s, 0.002, near);
    for (int k = 0; k < res.trajectory.size(); ++k) ASSERT_TRUE(near(res.trajectory.q.col(k))) << trial << " " << k;
    shrinks += res.shrinks;
    auto on_path = [&](const VecX& q) { return distanceToPolyline(q, wp) < 1e-9; };
    const JerkWaypointResult none = jerkLimitedThroughWaypoints(wp, r.vmax(), r.amax(), r.jmax(), s, 0.002, on_path);
    EXPECT_EQ(none.stops, none.interior_waypoints);
    const JointTrajectory rest = jerkLimitedTrajectory(wp, r.vmax(), r.amax(), r.jmax(), s, 0.002);
    ASSERT_EQ(none.trajectory.size(), rest.size());
    EXPECT_LT((none.trajectory.q - rest.q).cwiseAbs().maxCoeff(), 1e-12);
  }
  EXPECT_GT(shrinks, 0);
}

}  // namespace
}  // namespace mm
