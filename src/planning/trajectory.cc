#include "planning/trajectory.h"

#include <cmath>
#include <sstream>

#include "core/error.h"

namespace mm {

namespace {

// Normalized synchronized trapezoid: s(t) in [0,1] over [0,T] with acceleration time ta.
struct Profile {
  double T = 0, ta = 0;
  void eval(double t, double& s, double& sd, double& sdd) const {
    if (T <= 0) {
      s = 1, sd = 0, sdd = 0;
      return;
    }
    const double vp = 1.0 / (T - ta), a = vp / ta;
    if (t <= 0) s = 0, sd = 0, sdd = 0;
    else if (t < ta) s = 0.5 * a * t * t, sd = a * t, sdd = a;
    else if (t <= T - ta) s = 0.5 * a * ta * ta + vp * (t - ta), sd = vp, sdd = 0;
    else if (t < T) {
      const double r = T - t;
      s = 1 - 0.5 * a * r * r, sd = a * r, sdd = -a;
    } else s = 1, sd = 0, sdd = 0;
  }
};

// Samples a path of straight segments, each following its own normalized profile s(t) in [0, 1]
// over `steps` periods (any type with eval(t, s, sdot, sddot)); rest at every waypoint.
template <class Profile>
JointTrajectory sampleSegments(const std::vector<VecX>& wp, const std::vector<std::pair<Profile, int>>& segs, int total,
                               double dt) {
  JointTrajectory out = JointTrajectory::startingAt(wp[0], total, dt);
  int k = 1;
  for (size_t i = 0; i < segs.size(); ++i) {
    const auto& [p, steps] = segs[i];
    const VecX D = wp[i + 1] - wp[i];
    for (int s = 1; s <= steps; ++s, ++k) {
      double sv, sd, sdd;
      p.eval(s * dt, sv, sd, sdd);
      if (s == steps) sv = 1, sd = 0, sdd = 0;
      out.q.col(k) = wp[i] + sv * D;
      out.qd.col(k) = sd * D;
      out.qdd.col(k) = sdd * D;
    }
  }
  return out;
}

// Minimal T (and its ta) such that every joint j with displacement D_j stays within v_j and a_j:
// peak velocity D/(T-ta) <= v and acceleration D/((T-ta) ta) <= a.
Profile fastestProfile(const VecX& D, const VecX& v, const VecX& a) {
  double need_v = 0, need_a = 0, T_lo = 0;
  for (int j = 0; j < D.size(); ++j) {
    const double d = std::abs(D[j]);
    need_v = std::max(need_v, d / v[j]);  // (T - ta) >= need_v
    need_a = std::max(need_a, d / a[j]);  // (T - ta) ta >= need_a
    const double Tj = d > v[j] * v[j] / a[j] ? d / v[j] + v[j] / a[j] : 2 * std::sqrt(d / a[j]);
    T_lo = std::max(T_lo, Tj);
  }
  if (T_lo <= 0) return {};
  auto feasible = [&](double T, double& ta) {
    ta = std::min(T / 2, T - need_v);
    return ta > 0 && (T - ta) * ta >= need_a * (1 - 1e-12);
  };
  double ta = 0, hi = T_lo;
  while (!feasible(hi, ta)) hi *= 1.5;
  double lo = T_lo * 0.999;
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    double t2;
    if (feasible(mid, t2)) hi = mid;
    else lo = mid;
  }
  feasible(hi, ta);
  return {hi, ta};
}

}  // namespace

JointTrajectory trapezoidalTrajectory(const std::vector<VecX>& wp, const VecX& vmax, const VecX& amax,
                                      const LimitScaling& scale, double dt) {
  MM_DEMAND(!wp.empty() && dt > 0 && scale.velocity > 0 && scale.acceleration > 0);
  const VecX v = vmax * scale.velocity, a = amax * scale.acceleration;
  std::vector<std::pair<Profile, int>> segs;
  int total = 1;
  for (size_t i = 0; i + 1 < wp.size(); ++i) {
    Profile p = fastestProfile(wp[i + 1] - wp[i], v, a);
    const int steps = p.T > 0 ? static_cast<int>(std::ceil(p.T / dt - 1e-9)) : 0;
    if (steps > 0) {
      // Stretch to a whole number of periods, keeping the acceleration fraction (limits still hold).
      const double k = steps * dt / p.T;
      p.T *= k;
      p.ta *= k;
    }
    segs.push_back({p, steps});
    total += steps;
  }
  return sampleSegments(wp, segs, total, dt);
}

void differentiate(JointTrajectory& t) {
  const int N = t.size();
  t.qd.setZero(t.q.rows(), N);
  t.qdd.setZero(t.q.rows(), N);
  for (int k = 1; k + 1 < N; ++k) {
    t.qd.col(k) = (t.q.col(k + 1) - t.q.col(k - 1)) / (2 * t.dt);
    t.qdd.col(k) = (t.q.col(k + 1) - 2 * t.q.col(k) + t.q.col(k - 1)) / (t.dt * t.dt);
  }
}

LimitReport checkLimits(const JointTrajectory& t, const RobotModel& robot, double tol) {
  LimitReport r;
  for (int k = 0; k < t.size(); ++k) {
    for (int j = 0; j < robot.dof(); ++j) {
      if (t.q(j, k) < robot.lower()[j] - tol || t.q(j, k) > robot.upper()[j] + tol) {
        r.positions_ok = false;
        std::ostringstream s;
        s << "joint " << j + 1 << " position " << t.q(j, k) << " out of limits at sample " << k;
        r.worst = s.str();
      }
      const double vr = std::abs(t.qd(j, k)) / robot.vmax()[j];
      const double ar = std::abs(t.qdd(j, k)) / robot.amax()[j];
      if (vr > r.max_velocity_ratio) r.max_velocity_ratio = vr;
      if (ar > r.max_acceleration_ratio) r.max_acceleration_ratio = ar;
      r.rms_acceleration += t.qdd(j, k) * t.qdd(j, k);
      if (k > 0) {
        const double jerk = (t.qdd(j, k) - t.qdd(j, k - 1)) / t.dt;
        r.max_jerk_ratio = std::max(r.max_jerk_ratio, std::abs(jerk) / robot.jmax()[j]);
        r.rms_jerk += jerk * jerk;
      }
    }
  }
  const double samples = static_cast<double>(std::max(1, t.size())) * robot.dof();
  r.rms_acceleration = std::sqrt(r.rms_acceleration / samples);
  r.rms_jerk = std::sqrt(r.rms_jerk / samples);
  r.ok = r.positions_ok && r.max_velocity_ratio <= 1 + tol && r.max_acceleration_ratio <= 1 + tol;
  if (r.worst.empty() && !r.ok) {
    std::ostringstream s;
    s << "velocity ratio " << r.max_velocity_ratio << ", acceleration ratio " << r.max_acceleration_ratio;
    r.worst = s.str();
  }
  return r;
}

}  // namespace mm
