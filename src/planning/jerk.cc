#include "planning/jerk.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"

namespace mm {

// ---- one joint --------------------------------------------------------------------------------

double JerkProfile::totalDuration() const {
  double t = 0;
  for (int k = 0; k < phases; ++k) t += duration[k];
  return t;
}

void JerkProfile::eval(double t, double& p, double& v, double& a) const {
  p = p0, v = v0, a = 0;
  for (int k = 0; k < phases && t > 0; ++k) {
    const double h = std::min(t, duration[k]), j = jerk[k];
    p += v * h + a * h * h / 2 + j * h * h * h / 6;
    v += a * h + j * h * h / 2;
    a += j * h;
    t -= h;
  }
  if (t > 0) p += v * t;  // past the end: constant velocity (a is zero there)
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Duration of the fastest jerk-limited change of velocity by dv with zero acceleration at both
// ends: an acceleration trapezoid when |dv| >= A^2/J, else a triangle.
double changeTime(double dv, double A, double J) {
  dv = std::abs(dv);
  return dv >= A * A / J ? dv / A + A / J : 2 * std::sqrt(dv / J);
}

// "v0 -> vp -> vf" without cruise: distance and duration (each change is point-symmetric, so its
// mean velocity is the mean of its end velocities).
struct Peak {
  double d, t;
};
Peak peak(double v0, double vp, double vf, double A, double J) {
  const double t1 = changeTime(vp - v0, A, J), t2 = changeTime(vf - vp, A, J);
  return {0.5 * (v0 + vp) * t1 + 0.5 * (vp + vf) * t2, t1 + t2};
}

void addPhase(JerkProfile& p, double duration, double jerk) {
  if (duration <= 0) return;
  MM_DEMAND(p.phases < 7);
  p.duration[p.phases] = duration;
  p.jerk[p.phases] = jerk;
  ++p.phases;
}

void addChange(JerkProfile& p, double from, double to, double A, double J) {
  const double dv = std::abs(to - from), s = to > from ? 1.0 : -1.0;
  if (dv <= 0) return;
  if (dv >= A * A / J) {
    addPhase(p, A / J, s * J);
    addPhase(p, dv / A - A / J, 0);
    addPhase(p, A / J, -s * J);
  } else {
    const double tj = std::sqrt(dv / J);
    addPhase(p, tj, s * J);
    addPhase(p, tj, -s * J);
  }
}

// Bisection for a root of g between a and b (g(a), g(b) of opposite signs or zero).
template <class G>
double bisect(double a, double b, double ga, const G& g) {
  for (int it = 0; it < 80 && a != b; ++it) {
    const double m = 0.5 * (a + b), gm = g(m);
    if (gm == 0) return m;
    if ((gm < 0) == (ga < 0)) a = m, ga = gm;
    else b = m;
    if (std::abs(b - a) < 1e-14 * (1 + std::abs(a))) break;
  }
  return 0.5 * (a + b);
}

// The first root of g scanning from a towards b (a may exceed b), or NaN.
template <class G>
double firstRoot(double a, double b, const G& g, int grid = 24) {
  double xa = a, ga = g(a);
  if (std::abs(ga) < 1e-14) return a;
  for (int k = 1; k <= grid; ++k) {
    const double xb = a + (b - a) * k / grid, gb = g(xb);
    if (gb == 0) return xb;
    if ((ga < 0) != (gb < 0)) return bisect(xa, xb, ga, g);
    xa = xb, ga = gb;
  }
  return NAN;
}

}  // namespace

double jerkMinTime(double d, double v0, double vf, double V, double A, double J) {
  V = std::max({V, std::abs(v0), std::abs(vf)});
  double best = kInf;
  auto dist = [&](double vp) { return peak(v0, vp, vf, A, J).d - d; };
  // Up: the velocity peaks at vp >= max(v0, vf) (or cruises at V).
  {
    const double lo = std::max(v0, vf);
    const double r = firstRoot(lo, V, dist);
    if (!std::isnan(r)) best = std::min(best, peak(v0, r, vf, A, J).t);
    else {
      const Peak pk = peak(v0, V, vf, A, J);
      if (pk.d < d) best = std::min(best, pk.t + (d - pk.d) / V);
    }
  }
  // Down: the velocity dips to vp <= min(v0, vf) (or cruises at -V).
  {
    const double hi = std::min(v0, vf);
    const double r = firstRoot(hi, -V, dist);
    if (!std::isnan(r)) best = std::min(best, peak(v0, r, vf, A, J).t);
    else {
      const Peak pk = peak(v0, -V, vf, A, J);
      if (pk.d > d) best = std::min(best, pk.t + (pk.d - d) / V);
    }
  }
  return best;
}

bool jerkProfileForDuration(double p0, double pf, double v0, double vf, double V, double A, double J, double T,
                            JerkProfile& out) {
  out = JerkProfile{};
  out.p0 = p0, out.v0 = v0;
  const double d = pf - p0;
  V = std::max({V, std::abs(v0), std::abs(vf)});
  constexpr double tol = 1e-12;
  if (T <= tol) return std::abs(d) < 1e-12 && std::abs(vf - v0) < 1e-12;
  if (changeTime(vf - v0, A, J) > T + tol) return false;
  auto h = [&](double vp) { return peak(v0, vp, vf, A, J).t; };
  auto g = [&](double vp) {
    const Peak pk = peak(v0, vp, vf, A, J);
    return pk.d + vp * std::max(0.0, T - pk.t) - d;
  };
  // Ends of the peak velocities that fit in T (h grows away from [min(v0,vf), max(v0,vf)]).
  const double top = std::max(v0, vf), bottom = std::min(v0, vf);
  const double vhi = h(V) <= T ? V : bisect(top, V, h(top) - T, [&](double x) { return h(x) - T; });
  const double vlo = h(-V) <= T ? -V : bisect(bottom, -V, h(bottom) - T, [&](double x) { return h(x) - T; });
  constexpr int kGrid = 32;
  std::array<double, kGrid + 5> xs;
  int nx = 0;
  for (double x : {vlo, vhi, v0, vf})
    if (x >= vlo && x <= vhi) xs[nx++] = x;
  for (int k = 1; k < kGrid; ++k) xs[nx++] = vlo + (vhi - vlo) * k / kGrid;
  std::sort(xs.begin(), xs.begin() + nx);
  const size_t nxs = static_cast<size_t>(std::unique(xs.begin(), xs.begin() + nx) - xs.begin());
  // Roots of g on stretches where the peak fits; keep the one nearest the mean velocity d / T.
  double best = NAN;
  auto consider = [&](double x) {
    if (std::isnan(best) || std::abs(x - d / T) < std::abs(best - d / T)) best = x;
  };
  for (size_t k = 0; k < nxs; ++k) {
    if (h(xs[k]) > T + tol) continue;
    const double ga = g(xs[k]);
    if (std::abs(ga) < 1e-13) {
      consider(xs[k]);
      continue;
    }
    if (k + 1 == nxs || h(xs[k + 1]) > T + tol) continue;
    const double gb = g(xs[k + 1]);
    if ((ga < 0) == (gb < 0)) continue;
    // Bisection that stays where the peak fits in T.
    double a = xs[k], b = xs[k + 1], fa = ga;
    bool ok = true;
    for (int it = 0; it < 80 && std::abs(b - a) > 1e-14 * (1 + std::abs(a)); ++it) {
      const double m = 0.5 * (a + b);
      if (h(m) > T + tol) {
        ok = false;
        break;
      }
      const double gm = g(m);
      if ((gm < 0) == (fa < 0)) a = m, fa = gm;
      else b = m;
    }
    if (ok) consider(0.5 * (a + b));
  }
  if (std::isnan(best)) return false;
  const double vp = best;
  addChange(out, v0, vp, A, J);
  addPhase(out, T - h(vp), 0);
  addChange(out, vp, vf, A, J);
  return true;
}

// ---- many joints, many waypoints ---------------------------------------------------------------

namespace {

// Rest-to-rest double-S profile over unit distance with limits V, A, J (all > 0), Biagiotti &
// Melchiorri, "Trajectory Planning for Automatic Machines and Robots", 2008, sec. 3.4.
struct DoubleS {
  double Tj = 0, Ta = 0, Tv = 0, J = 0;  // jerk time, acceleration time, cruise time, jerk
  double T() const { return 2 * Ta + Tv; }
  static DoubleS fastest(double V, double A, double J) {
    DoubleS p;
    p.J = J;
    if (V * J >= A * A) p.Tj = A / J, p.Ta = p.Tj + V / A;  // eq. 3.19
    else p.Tj = std::sqrt(V / J), p.Ta = 2 * p.Tj;
    p.Tv = 1.0 / V - p.Ta;
    if (p.Tv < 0) {  // V is not reached (eq. 3.25-3.26, symmetric case)
      p.Tv = 0;
      if (1.0 >= 2 * A * A * A / (J * J)) {
        p.Tj = A / J;
        p.Ta = 0.5 * p.Tj + std::sqrt(0.25 * p.Tj * p.Tj + 1.0 / A);
      } else {
        p.Tj = std::cbrt(1.0 / (2 * J));
        p.Ta = 2 * p.Tj;
      }
    }
    return p;
  }
  // The same motion for one joint moving by D: the jerks scale with D.
  JerkProfile joint(double p0, double D) const {
    JerkProfile jp;
    jp.p0 = p0;
    const double Tc = Ta - 2 * Tj;
    const double ds[7] = {Tj, Tc, Tj, Tv, Tj, Tc, Tj};
    const double js[7] = {J, 0, -J, 0, -J, 0, J};
    for (int k = 0; k < 7; ++k) addPhase(jp, ds[k], js[k] * D);
    return jp;
  }
};

struct Segment {
  std::vector<JerkProfile> joints;
  int steps = 0;
  bool straight = false;  // rests at both ends, on the straight line
};

struct Limits {
  VecX V, A, J;
};

// Rest to rest on the straight line: every joint follows one normalized double-S.
Segment restSegment(const VecX& q0, const VecX& qf, const Limits& L, double dt) {
  const int n = static_cast<int>(q0.size());
  const VecX D = qf - q0;
  double V = kInf, A = kInf, J = kInf;
  for (int k = 0; k < n; ++k)
    if (std::abs(D[k]) > 1e-12) {
      V = std::min(V, L.V[k] / std::abs(D[k]));
      A = std::min(A, L.A[k] / std::abs(D[k]));
      J = std::min(J, L.J[k] / std::abs(D[k]));
    }
  Segment s;
  s.straight = true;
  if (!std::isfinite(V)) {
    for (int k = 0; k < n; ++k) s.joints.push_back(DoubleS{}.joint(q0[k], 0));
    return s;
  }
  DoubleS p = DoubleS::fastest(V, A, J);
  s.steps = static_cast<int>(std::ceil(p.T() / dt - 1e-9));
  // Whole periods: stretch time by k >= 1 (velocity / k, acceleration / k^2, jerk / k^3).
  const double k = s.steps * dt / p.T();
  p.Tj *= k, p.Ta *= k, p.Tv *= k, p.J /= k * k * k;
  for (int j = 0; j < n; ++j) s.joints.push_back(p.joint(q0[j], D[j]));
  return s;
}

double segmentMinTime(const VecX& q0, const VecX& qf, const VecX& v0, const VecX& vf, const Limits& L) {
  double T = 0;
  for (int j = 0; j < q0.size(); ++j) T = std::max(T, jerkMinTime(qf[j] - q0[j], v0[j], vf[j], L.V[j], L.A[j], L.J[j]));
  return T;
}

// The shortest duration all joints can share: from the slowest joint's minimum time upwards (a
// joint may have durations it cannot take, Ruckig's "blocked intervals": moving fast, it cannot
// cover a short distance slowly without turning back). On whole periods of `dt` if `whole`, else
// continuous (steps of 1%). Fills the profiles; false if none was found.
double syncDuration(const VecX& q0, const VecX& qf, const VecX& v0, const VecX& vf, const Limits& L, double dt,
                    bool whole, std::vector<JerkProfile>& joints) {
  const int n = static_cast<int>(q0.size());
  const double T0 = segmentMinTime(q0, qf, v0, vf, L);
  if (!std::isfinite(T0)) return kInf;
  joints.resize(n);
  double T = whole ? std::max(1.0, std::ceil(T0 / dt - 1e-9)) * dt : T0 * (1 + 1e-9) + 1e-12;
  for (int attempt = 0; attempt < 200; ++attempt) {
    bool all = true;
    for (int j = 0; j < n && all; ++j)
      all = jerkProfileForDuration(q0[j], qf[j], v0[j], vf[j], L.V[j], L.A[j], L.J[j], T, joints[j]);
    if (all) return T;
    T = whole ? T + std::max(1.0, std::floor(T / dt / 50)) * dt : T * 1.01;
  }
  return kInf;
}

// All joints synchronized to the slowest, on whole periods; false if no common duration was found.
bool syncSegment(const VecX& q0, const VecX& qf, const VecX& v0, const VecX& vf, const Limits& L, double dt,
                 Segment& s) {
  if (v0.isZero(0) && vf.isZero(0)) {
    s = restSegment(q0, qf, L, dt);
    return true;
  }
  s = Segment{};
  const double T = syncDuration(q0, qf, v0, vf, L, dt, true, s.joints);
  if (!std::isfinite(T)) return false;
  s.steps = static_cast<int>(std::lround(T / dt));
  return true;
}

// Writes samples 1..steps of a segment into columns k0+1.. of the trajectory; the last one is the
// exact end state (qf, vf, 0).
void sampleSegment(const Segment& s, const VecX& qf, const VecX& vf, double dt, JointTrajectory& out, int k0) {
  const int n = static_cast<int>(s.joints.size());
  for (int i = 1; i <= s.steps; ++i) {
    for (int j = 0; j < n; ++j) {
      double p, v, a;
      if (i == s.steps) p = qf[j], v = vf[j], a = 0;
      else s.joints[j].eval(i * dt, p, v, a);
      out.q(j, k0 + i) = p, out.qd(j, k0 + i) = v, out.qdd(j, k0 + i) = a;
    }
  }
}

// The trajectory of consecutive segments from rest at wp[0]; v(i) is the velocity at wp[i].
template <class Vel>
JointTrajectory assemble(const std::vector<VecX>& wp, const std::vector<Segment>& seg, const Vel& v, double dt) {
  const int n = static_cast<int>(wp[0].size());
  int total = 1;
  for (const Segment& s : seg) total += s.steps;
  JointTrajectory out;
  out.dt = dt;
  out.q.resize(n, total);
  out.qd.resize(n, total);
  out.qdd.resize(n, total);
  out.q.col(0) = wp[0];
  out.qd.col(0).setZero();
  out.qdd.col(0).setZero();
  int k = 0;
  for (size_t s = 0; s < seg.size(); ++s) {
    sampleSegment(seg[s], wp[s + 1], v(static_cast<int>(s) + 1), dt, out, k);
    k += seg[s].steps;
  }
  return out;
}

}  // namespace

JerkWaypointResult jerkLimitedThroughWaypoints(const std::vector<VecX>& waypoints, const VecX& vmax, const VecX& amax,
                                               const VecX& jmax, const LimitScaling& scale, double dt,
                                               const std::function<bool(const VecX&)>& valid) {
  MM_DEMAND(!waypoints.empty() && dt > 0 && scale.velocity > 0 && scale.acceleration > 0);
  const Limits L{vmax * scale.velocity, amax * scale.acceleration, jmax * scale.acceleration};
  const int n = static_cast<int>(waypoints[0].size());
  // Repeated waypoints carry no motion.
  std::vector<VecX> wp = {waypoints[0]};
  for (size_t i = 1; i < waypoints.size(); ++i)
    if ((waypoints[i] - wp.back()).norm() > 1e-12) wp.push_back(waypoints[i]);
  const int W = static_cast<int>(wp.size());
  JerkWaypointResult res;
  res.interior_waypoints = std::max(0, W - 2);

  // Velocity direction at each interior waypoint: the bisector of the unit directions in and out,
  // measured in velocity-limit units, scaled so that lambda = 1 puts one joint at its limit.
  std::vector<VecX> dir(W, VecX::Zero(n));
  for (int i = 1; i + 1 < W; ++i) {
    VecX in = (wp[i] - wp[i - 1]).cwiseQuotient(L.V), out = (wp[i + 1] - wp[i]).cwiseQuotient(L.V);
    VecX b = in.normalized() + out.normalized();
    if (b.norm() < 1e-6) continue;  // a reversal: rest there
    b = b.cwiseProduct(L.V);
    dir[i] = b / b.cwiseQuotient(L.V).cwiseAbs().maxCoeff();
  }
  std::vector<double> lambda(W, 0.0);
  auto vel = [&](int i) -> VecX { return lambda[i] * dir[i]; };
  std::vector<JerkProfile> scratch;
  auto cost = [&](int i) {  // time of the two segments around waypoint i
    return syncDuration(wp[i - 1], wp[i], vel(i - 1), vel(i), L, dt, false, scratch) +
           syncDuration(wp[i], wp[i + 1], vel(i), vel(i + 1), L, dt, false, scratch);
  };
  // Coordinate descent on the waypoint speeds: a coarse scan, then golden-section search.
  for (int sweep = 0; sweep < 2; ++sweep)
    for (int i = 1; i + 1 < W; ++i) {
      if (dir[i].isZero(0)) continue;
      double best_l = lambda[i], best_c = cost(i);
      for (int k = 0; k <= 5; ++k) {
        lambda[i] = k / 5.0;
        const double c = cost(i);
        if (c < best_c) best_c = c, best_l = lambda[i];
      }
      double a = std::max(0.0, best_l - 0.2), b = std::min(1.0, best_l + 0.2);
      const double g = 0.5 * (std::sqrt(5.0) - 1);
      double x1 = b - g * (b - a), x2 = a + g * (b - a);
      lambda[i] = x1;
      double f1 = cost(i);
      lambda[i] = x2;
      double f2 = cost(i);
      for (int it = 0; it < 14; ++it) {
        if (f1 < f2) {
          b = x2, x2 = x1, f2 = f1, x1 = b - g * (b - a);
          lambda[i] = x1;
          f1 = cost(i);
        } else {
          a = x1, x1 = x2, f1 = f2, x2 = a + g * (b - a);
          lambda[i] = x2;
          f2 = cost(i);
        }
      }
      const double xm = f1 < f2 ? x1 : x2, fm = std::min(f1, f2);
      lambda[i] = fm < best_c ? xm : best_l;
    }

  // Build the segments; where one cannot be synchronized or leaves the valid space, shrink the
  // speeds at its ends (halving, then zero: a segment resting at both ends is the straight one
  // the planner validated).
  std::vector<Segment> seg(W - 1);
  std::vector<bool> dirty(W - 1, true);
  for (int round = 0; round < 64; ++round) {
    std::vector<int> bad;
    for (int s = 0; s + 1 < W; ++s) {
      if (!dirty[s]) continue;
      dirty[s] = false;
      if (!syncSegment(wp[s], wp[s + 1], vel(s), vel(s + 1), L, dt, seg[s])) {
        bad.push_back(s);
        continue;
      }
      if (valid && !seg[s].straight) {
        VecX q(n);
        for (int i = 1; i < seg[s].steps; ++i) {
          double p, v, a;
          for (int j = 0; j < n; ++j) seg[s].joints[j].eval(i * dt, p, v, a), q[j] = p;
          if (!valid(q)) {
            bad.push_back(s);
            break;
          }
        }
      }
    }
    if (bad.empty()) break;
    for (int s : bad)
      for (int i : {s, s + 1}) {
        if (i == 0 || i == W - 1 || lambda[i] == 0) continue;
        lambda[i] = round < 5 ? 0.5 * lambda[i] : 0.0;
        ++res.shrinks;
        if (i > 0) dirty[i - 1] = true;
        if (i < W - 1) dirty[i] = true;
      }
  }
  for (int i = 1; i + 1 < W; ++i) res.stops += lambda[i] == 0;

  res.trajectory = assemble(wp, seg, vel, dt);
  res.waypoint_samples = {0};
  for (const Segment& s : seg) res.waypoint_samples.push_back(res.waypoint_samples.back() + s.steps);
  return res;
}

JointTrajectory jerkLimitedTrajectory(const std::vector<VecX>& waypoints, const VecX& vmax, const VecX& amax,
                                      const VecX& jmax, const LimitScaling& scale, double dt) {
  MM_DEMAND(!waypoints.empty() && dt > 0 && scale.velocity > 0 && scale.acceleration > 0);
  const Limits L{vmax * scale.velocity, amax * scale.acceleration, jmax * scale.acceleration};
  std::vector<Segment> seg;
  for (size_t i = 0; i + 1 < waypoints.size(); ++i) seg.push_back(restSegment(waypoints[i], waypoints[i + 1], L, dt));
  const VecX zero = VecX::Zero(waypoints[0].size());
  return assemble(waypoints, seg, [&](int) { return zero; }, dt);
}

}  // namespace mm
