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
  p = p0, v = v0, a = a0;
  for (int k = 0; k < phases && t > 0; ++k) {
    const double h = std::min(t, duration[k]), j = jerk[k];
    p += v * h + a * h * h / 2 + j * h * h * h / 6;
    v += a * h + j * h * h / 2;
    a += j * h;
    t -= h;
  }
  if (t > 0) p += v * t + a * t * t / 2, v += a * t;  // past the end: constant acceleration
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

void addPhase(JerkProfile& p, double duration, double jerk) {
  if (duration <= 0) return;
  MM_DEMAND(p.phases < 7);
  p.duration[p.phases] = duration;
  p.jerk[p.phases] = jerk;
  ++p.phases;
}

// The velocity reached from (v, a) by bringing the acceleration to zero at once.
double settle(double v, double a, double J) { return v + a * std::abs(a) / (2 * J); }

// The fastest jerk-limited change from (v, a) to (w, 0): the acceleration ramps to a peak ap (at
// most A) in the direction of w, holds, and ramps to zero. Duration and distance; the (up to 3)
// phases are written to `ph` if given.
struct Change {
  double t = 0, d = 0;
};
Change fastestChange(double v, double a, double w, double A, double J, std::array<std::pair<double, double>, 3>* ph) {
  if (a == 0 && !ph) {  // the common case, in closed form: a point-symmetric change, mean velocity (v + w) / 2
    const double dv = std::abs(w - v);
    const double t = dv >= A * A / J ? dv / A + A / J : 2 * std::sqrt(dv / J);
    return {t, 0.5 * (v + w) * t};
  }
  const double s = w >= settle(v, a, J) ? 1.0 : -1.0;
  const double a1 = s * a, dv = s * (w - v);  // in the frame where the change goes up
  double ap = std::sqrt(std::max(0.0, J * dv + a1 * a1 / 2)), th = 0;
  if (ap > A) ap = A, th = std::max(0.0, (dv - (2 * A * A - a1 * a1) / (2 * J)) / A);
  const double t1 = std::max(0.0, (ap - a1) / J), t3 = ap / J, j = s * J, sa = s * ap;
  if (ph) *ph = {{{t1, j}, {th, 0.0}, {t3, -j}}};
  // Distance, phase by phase (ramp up, hold, ramp down).
  double d = v * t1 + a * t1 * t1 / 2 + j * t1 * t1 * t1 / 6;
  const double v1 = v + a * t1 + j * t1 * t1 / 2;
  d += v1 * th + sa * th * th / 2;
  const double v2 = v1 + sa * th;
  d += v2 * t3 + sa * t3 * t3 / 2 - j * t3 * t3 * t3 / 6;
  return {t1 + th + t3, d};
}

// "(v0, a0) -> (vp, 0) -> (vf, af)" without cruise: the second change is the time reverse of the
// fastest change from (-vf, af) to (-vp, 0).
struct Peak {
  double d, t;
};
Peak peak(double v0, double a0, double vp, double vf, double af, double A, double J) {
  const Change c1 = fastestChange(v0, a0, vp, A, J, nullptr), c3 = fastestChange(-vf, af, -vp, A, J, nullptr);
  return {c1.d - c3.d, c1.t + c3.t};
}

void addPeakProfile(JerkProfile& p, double v0, double a0, double vp, double cruise, double vf, double af, double A,
                    double J) {
  std::array<std::pair<double, double>, 3> ph;
  fastestChange(v0, a0, vp, A, J, &ph);
  for (const auto& [h, j] : ph) addPhase(p, h, j);
  addPhase(p, cruise, 0);
  fastestChange(-vf, af, -vp, A, J, &ph);
  for (int k = 2; k >= 0; --k) addPhase(p, ph[k].first, -ph[k].second);  // reversed in time
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

// Roots of g scanning from a towards b (a may exceed b): the first one, or all (callback).
template <class G, class F>
void roots(double a, double b, const G& g, int grid, bool first_only, const F& found) {
  double xa = a, ga = g(a);
  if (std::abs(ga) < 1e-14) {
    found(a);
    if (first_only) return;
  }
  for (int k = 1; k <= grid; ++k) {
    const double xb = a + (b - a) * k / grid, gb = g(xb);
    if (gb == 0 || (ga < 0) != (gb < 0)) {
      found(gb == 0 ? xb : bisect(xa, xb, ga, g));
      if (first_only) return;
    }
    xa = xb, ga = gb;
  }
}

bool stateFeasible(double v, double a, double V, double A, double J) {
  return std::abs(a) <= A * (1 + 1e-12) && std::abs(v) + a * a / (2 * J) <= V * (1 + 1e-12);
}

}  // namespace

double jerkMinTime(double d, double v0, double a0, double vf, double af, double V, double A, double J) {
  if (!stateFeasible(v0, a0, V, A, J) || !stateFeasible(vf, af, V, A, J)) return kInf;
  const double s0 = settle(v0, a0, J), s3 = settle(vf, -af, J);  // where each change turns
  const double top = std::max(s0, s3), bottom = std::min(s0, s3);
  double best = kInf;
  auto dist = [&](double vp) { return peak(v0, a0, vp, vf, af, A, J).d - d; };
  auto take = [&](double vp) { best = std::min(best, peak(v0, a0, vp, vf, af, A, J).t); };
  // Up: the velocity peaks at vp >= top (time grows with vp: the first root), or cruises at V.
  bool found = false;
  roots(top, V, dist, 24, true, [&](double x) { take(x), found = true; });
  if (!found) {
    const Peak pk = peak(v0, a0, V, vf, af, A, J);
    if (pk.d < d) best = std::min(best, pk.t + (d - pk.d) / V);
  }
  // Down: the velocity dips to vp <= bottom, or cruises at -V.
  found = false;
  roots(bottom, -V, dist, 24, true, [&](double x) { take(x), found = true; });
  if (!found) {
    const Peak pk = peak(v0, a0, -V, vf, af, A, J);
    if (pk.d > d) best = std::min(best, pk.t + (pk.d - d) / V);
  }
  // Between: the velocity passes vp with zero acceleration on its way; only with accelerations at
  // the ends can this be the fastest (with none, going straight to vf is faster).
  if (top > bottom && (a0 != 0 || af != 0)) roots(bottom, top, dist, 8, false, take);
  return best;
}

bool jerkProfileForDuration(double p0, double pf, double v0, double a0, double vf, double af, double V, double A,
                            double J, double T, JerkProfile& out) {
  out = JerkProfile{};
  out.p0 = p0, out.v0 = v0, out.a0 = a0;
  const double d = pf - p0;
  if (!stateFeasible(v0, a0, V, A, J) || !stateFeasible(vf, af, V, A, J)) return false;
  constexpr double tol = 1e-12;
  if (T <= tol) return std::abs(d) < 1e-12 && std::abs(vf - v0) < 1e-12 && std::abs(af - a0) < 1e-12;
  auto h = [&](double vp) { return peak(v0, a0, vp, vf, af, A, J).t; };
  auto g = [&](double vp) {
    const Peak pk = peak(v0, a0, vp, vf, af, A, J);
    return pk.d + vp * std::max(0.0, T - pk.t) - d;
  };
  // Ends of the peak velocities that fit in T (h grows away from [bottom, top]).
  const double s0 = settle(v0, a0, J), s3 = settle(vf, -af, J);
  const double top = std::max(s0, s3), bottom = std::min(s0, s3);
  const double vhi = h(V) <= T ? V : h(top) > T ? top : bisect(top, V, h(top) - T, [&](double x) { return h(x) - T; });
  const double vlo = h(-V) <= T ? -V : h(bottom) > T ? bottom : bisect(bottom, -V, h(bottom) - T, [&](double x) { return h(x) - T; });
  constexpr int kGrid = 32, kExtra = 24;
  std::array<double, kGrid + 5 + kExtra> xs;
  int nx = 0;
  for (double x : {vlo, vhi, s0, s3})
    if (x >= vlo && x <= vhi) xs[nx++] = x;
  for (int k = 1; k < kGrid; ++k) xs[nx++] = vlo + (vhi - vlo) * k / kGrid;
  if (a0 != 0 || af != 0) {
    // Between bottom and top, h is not monotone: the peaks that fit in T can form small islands
    // the grid misses. Each root of the cruise-free distance that fits is such an island: add it
    // and the island's ends.
    const double step = (top - bottom) / 16;
    roots(bottom, top, [&](double x) { return peak(v0, a0, x, vf, af, A, J).d - d; }, 16, false, [&](double r) {
      if (h(r) > T + tol || nx + 3 > static_cast<int>(xs.size())) return;
      xs[nx++] = r;
      for (double dir : {-1.0, 1.0}) {
        const double e = std::clamp(r + dir * step, bottom, top);
        xs[nx++] = h(e) <= T ? e : bisect(r, e, h(r) - T, [&](double x) { return h(x) - T; });
      }
    });
  }
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
  addPeakProfile(out, v0, a0, best, std::max(0.0, T - h(best)), vf, af, A, J);
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

// A waypoint's state: velocity and acceleration per joint.
struct WpState {
  VecX v, a;
  bool rest() const { return v.isZero(0) && a.isZero(0); }
};

double segmentMinTime(const VecX& q0, const VecX& qf, const WpState& s0, const WpState& sf, const Limits& L) {
  double T = 0;
  for (int j = 0; j < q0.size(); ++j)
    T = std::max(T, jerkMinTime(qf[j] - q0[j], s0.v[j], s0.a[j], sf.v[j], sf.a[j], L.V[j], L.A[j], L.J[j]));
  return T;
}

// The shortest duration all joints can share: from the slowest joint's minimum time upwards (a
// joint may have durations it cannot take, Ruckig's "blocked intervals": moving fast, it cannot
// cover a short distance slowly without turning back). On whole periods of `dt` if `whole`, else
// continuous (steps of 1%). Fills the profiles; false if none was found.
double syncDuration(const VecX& q0, const VecX& qf, const WpState& s0, const WpState& sf, const Limits& L, double dt,
                    bool whole, std::vector<JerkProfile>& joints) {
  const int n = static_cast<int>(q0.size());
  const double T0 = segmentMinTime(q0, qf, s0, sf, L);
  if (!std::isfinite(T0)) return kInf;
  joints.resize(n);
  double T = whole ? std::max(1.0, std::ceil(T0 / dt - 1e-9)) * dt : T0 * (1 + 1e-9) + 1e-12;
  for (int attempt = 0; attempt < 200; ++attempt) {
    bool all = true;
    for (int j = 0; j < n && all; ++j)
      all = jerkProfileForDuration(q0[j], qf[j], s0.v[j], s0.a[j], sf.v[j], sf.a[j], L.V[j], L.A[j], L.J[j], T, joints[j]);
    if (all) return T;
    T = whole ? T + std::max(1.0, std::floor(T / dt / 50)) * dt : T * 1.01;
  }
  return kInf;
}

// All joints synchronized to the slowest, on whole periods; false if no common duration was found.
bool syncSegment(const VecX& q0, const VecX& qf, const WpState& s0, const WpState& sf, const Limits& L, double dt,
                 Segment& s) {
  if (s0.rest() && sf.rest()) {
    s = restSegment(q0, qf, L, dt);
    return true;
  }
  s = Segment{};
  const double T = syncDuration(q0, qf, s0, sf, L, dt, true, s.joints);
  if (!std::isfinite(T)) return false;
  s.steps = static_cast<int>(std::lround(T / dt));
  return true;
}

// Writes samples 1..steps of a segment into columns k0+1.. of the trajectory; the last one is the
// exact end state (qf, sf).
void sampleSegment(const Segment& s, const VecX& qf, const WpState& sf, double dt, JointTrajectory& out, int k0) {
  const int n = static_cast<int>(s.joints.size());
  for (int i = 1; i <= s.steps; ++i) {
    for (int j = 0; j < n; ++j) {
      double p, v, a;
      if (i == s.steps) p = qf[j], v = sf.v[j], a = sf.a[j];
      else s.joints[j].eval(i * dt, p, v, a);
      out.q(j, k0 + i) = p, out.qd(j, k0 + i) = v, out.qdd(j, k0 + i) = a;
    }
  }
}

// The trajectory of consecutive segments from rest at wp[0]; state(i) is the state at wp[i].
template <class State>
JointTrajectory assemble(const std::vector<VecX>& wp, const std::vector<Segment>& seg, const State& state, double dt) {
  int total = 1;
  for (const Segment& s : seg) total += s.steps;
  JointTrajectory out = JointTrajectory::startingAt(wp[0], total, dt);
  int k = 0;
  for (size_t s = 0; s < seg.size(); ++s) {
    sampleSegment(seg[s], wp[s + 1], state(static_cast<int>(s) + 1), dt, out, k);
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

  // At each interior waypoint the velocity points along the bisector of the unit directions in and
  // out (in velocity-limit units), scaled so that lambda = 1 puts one joint at its limit; the
  // acceleration there is zero. (Searching an acceleration along the turn as well, which the
  // one-joint profiles allow, gained 0.5% in duration on CHOMP's curving paths for 4x the
  // computation, so it is not done.)
  std::vector<VecX> vdir(W, VecX::Zero(n));
  for (int i = 1; i + 1 < W; ++i) {
    const VecX in = (wp[i] - wp[i - 1]).cwiseQuotient(L.V).normalized(), out = (wp[i + 1] - wp[i]).cwiseQuotient(L.V).normalized();
    VecX b = in + out;
    if (b.norm() < 1e-6) continue;  // a reversal: rest there
    b = b.cwiseProduct(L.V);
    vdir[i] = b / b.cwiseQuotient(L.V).cwiseAbs().maxCoeff();
  }
  std::vector<double> lambda(W, 0.0);
  const VecX zero = VecX::Zero(n);
  auto state = [&](int i) -> WpState { return {lambda[i] * vdir[i], zero}; };
  std::vector<JerkProfile> scratch;
  auto cost = [&](int i) {  // time of the two segments around waypoint i
    return syncDuration(wp[i - 1], wp[i], state(i - 1), state(i), L, dt, false, scratch) +
           syncDuration(wp[i], wp[i + 1], state(i), state(i + 1), L, dt, false, scratch);
  };
  // One coordinate at a time: a coarse scan of [0, 1], then golden-section search around the best.
  auto search = [&](int i, double& x) {
    double best_x = x, best_c = cost(i);
    for (int k = 0; k <= 5; ++k) {
      x = k / 5.0;
      const double c = cost(i);
      if (c < best_c) best_c = c, best_x = x;
    }
    double a = std::max(0.0, best_x - 0.2), b = std::min(1.0, best_x + 0.2);
    const double g = 0.5 * (std::sqrt(5.0) - 1);
    double x1 = b - g * (b - a), x2 = a + g * (b - a);
    x = x1;
    double f1 = cost(i);
    x = x2;
    double f2 = cost(i);
    for (int it = 0; it < 12; ++it) {
      if (f1 < f2) {
        b = x2, x2 = x1, f2 = f1, x1 = b - g * (b - a);
        x = x1;
        f1 = cost(i);
      } else {
        a = x1, x1 = x2, f1 = f2, x2 = a + g * (b - a);
        x = x2;
        f2 = cost(i);
      }
    }
    x = std::min(f1, f2) < best_c ? (f1 < f2 ? x1 : x2) : best_x;
  };
  for (int sweep = 0; sweep < 2; ++sweep)
    for (int i = 1; i + 1 < W; ++i)
      if (!vdir[i].isZero(0)) search(i, lambda[i]);

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
      if (!syncSegment(wp[s], wp[s + 1], state(s), state(s + 1), L, dt, seg[s])) {
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

  res.trajectory = assemble(wp, seg, state, dt);
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
  const WpState rest{VecX::Zero(waypoints[0].size()), VecX::Zero(waypoints[0].size())};
  return assemble(waypoints, seg, [&](int) { return rest; }, dt);
}

}  // namespace mm
