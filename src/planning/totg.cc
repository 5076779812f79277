#include "planning/totg.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "core/error.h"

namespace mm {
namespace {

// One piece of the path, arc-length parameterized on [0, length].
struct Segment {
  bool arc = false;
  double length = 0;
  VecX start, dir;     // linear: q = start + s dir
  VecX center, x, y;   // arc: q = center + r (x cos(s/r) + y sin(s/r))
  double r = 0;
  void eval(double s, VecX& q, VecX& dq, VecX& ddq) const {
    if (!arc) {
      q = start + s * dir;
      dq = dir;
      ddq.setZero(dir.size());
      return;
    }
    const double c = std::cos(s / r), sn = std::sin(s / r);
    q = center + r * (x * c + y * sn);
    dq = -x * sn + y * c;
    ddq = -(x * c + y * sn) / r;
  }
};

// Straight segments between the waypoints, each corner replaced by a circular arc tangent to both
// segments and within max_deviation of the corner (Kunz & Stilman, sec. IV). A corner that turns
// back on itself (or an option of 0) keeps the corner: the profile then stops there.
std::vector<Segment> blendedPath(const std::vector<VecX>& w, double max_dev) {
  std::vector<Segment> out;
  const size_t n = w.size();
  VecX from = w[0];
  for (size_t i = 1; i < n; ++i) {
    const VecX d_in = w[i] - w[i - 1];
    Segment lin;
    lin.start = from;
    if (i + 1 < n && max_dev > 0) {
      const VecX d_out = w[i + 1] - w[i];
      const double len_in = d_in.norm(), len_out = d_out.norm();
      const VecX y_in = d_in / len_in, y_out = d_out / len_out;
      const double cos_a = std::clamp(y_in.dot(y_out), -1.0, 1.0), alpha = std::acos(cos_a);
      if (alpha > 1e-6 && alpha < M_PI - 1e-3) {
        // Distance from the corner to the tangent points: half the shorter segment at most, and
        // what keeps the arc within max_dev of the corner.
        const double l = std::min({0.5 * len_in, 0.5 * len_out, max_dev * std::sin(alpha / 2) / (1 - std::cos(alpha / 2))});
        const double r = l / std::tan(alpha / 2);
        const VecX bis = (y_out - y_in).normalized();
        Segment arc;
        arc.arc = true;
        arc.r = r;
        arc.center = w[i] + bis * (r / std::cos(alpha / 2));
        const VecX tangent_in = w[i] - l * y_in;
        arc.x = (tangent_in - arc.center).normalized();
        arc.y = y_in;
        arc.length = alpha * r;
        lin.dir = y_in;
        lin.length = (tangent_in - from).norm();
        if (lin.length > 1e-12) out.push_back(lin);
        out.push_back(arc);
        from = w[i] + l * y_out;
        continue;
      }
    }
    lin.dir = (w[i] - from).normalized();
    lin.length = (w[i] - from).norm();
    if (lin.length > 1e-12) out.push_back(lin);
    from = w[i];
  }
  return out;
}

// Within a cell of length h, sddot is constant: sddot = (x1 - x0) / (2h). Each joint's acceleration
// q'(s) sddot + q''(s) x must stay within +-a at both ends of the cell. For the unknown u (x1 going
// forward, x0 going backward) each condition is |c u + d| <= a; this returns the largest u
// satisfying all of them (or, if none does, the largest under the upper bounds alone).
double largestFeasible(const std::vector<std::pair<double, double>>& cd, const VecX& a, double cap) {
  double lo = 0, hi = cap;
  for (size_t k = 0; k < cd.size(); ++k) {
    const auto [c, d] = cd[k];
    const double ak = a[static_cast<int>(k % a.size())];
    if (std::abs(c) < 1e-15) continue;
    const double b1 = (ak - d) / c, b2 = (-ak - d) / c;
    hi = std::min(hi, std::max(b1, b2));
    lo = std::max(lo, std::min(b1, b2));
  }
  return std::max(0.0, hi);  // if lo > hi the cell is infeasible from here; the other pass repairs it
}

double forwardStep(double x0, const VecX& dq0, const VecX& ddq0, const VecX& dq1, const VecX& ddq1, double h,
                   const VecX& a, double cap, std::vector<std::pair<double, double>>& cd) {
  const int n = static_cast<int>(a.size());
  cd.resize(2 * n);
  for (int i = 0; i < n; ++i) {
    // start: dq0 (x1 - x0)/(2h) + ddq0 x0 ; end: dq1 (x1 - x0)/(2h) + ddq1 x1
    cd[i] = {dq0[i] / (2 * h), -dq0[i] * x0 / (2 * h) + ddq0[i] * x0};
    cd[n + i] = {dq1[i] / (2 * h) + ddq1[i], -dq1[i] * x0 / (2 * h)};
  }
  return largestFeasible(cd, a, cap);
}

double backwardStep(double x1, const VecX& dq0, const VecX& ddq0, const VecX& dq1, const VecX& ddq1, double h,
                    const VecX& a, double cap, std::vector<std::pair<double, double>>& cd) {
  const int n = static_cast<int>(a.size());
  cd.resize(2 * n);
  for (int i = 0; i < n; ++i) {
    // start: dq0 (x1 - x0)/(2h) + ddq0 x0 ; end: dq1 (x1 - x0)/(2h) + ddq1 x1, unknown x0
    cd[i] = {-dq0[i] / (2 * h) + ddq0[i], dq0[i] * x1 / (2 * h)};
    cd[n + i] = {-dq1[i] / (2 * h), dq1[i] * x1 / (2 * h) + ddq1[i] * x1};
  }
  return largestFeasible(cd, a, cap);
}

// The largest sdot^2 at which the acceleration bounds are consistent and the velocity limits hold.
double maxX(const VecX& dq, const VecX& ddq, const VecX& v, const VecX& a) {
  double x = INFINITY;
  const int n = static_cast<int>(dq.size());
  for (int i = 0; i < n; ++i) {
    if (std::abs(dq[i]) > 1e-12) x = std::min(x, (v[i] * v[i]) / (dq[i] * dq[i]));
    else if (std::abs(ddq[i]) > 1e-12) x = std::min(x, a[i] / std::abs(ddq[i]));  // joint at rest on the path
  }
  // Pairs: the intervals from joints i and j intersect (Kunz & Stilman eq. 19).
  for (int i = 0; i < n; ++i) {
    if (std::abs(dq[i]) < 1e-12) continue;
    for (int j = i + 1; j < n; ++j) {
      if (std::abs(dq[j]) < 1e-12) continue;
      const double k = std::abs(ddq[i] / dq[i] - ddq[j] / dq[j]);
      if (k > 1e-12) x = std::min(x, (a[i] / std::abs(dq[i]) + a[j] / std::abs(dq[j])) / k);
    }
  }
  return x;
}

// `margin[k]` scales the limits on path segment k (1: the limits themselves). `sample_seg` gets the
// path segment of every sample.
JointTrajectory integrate(const std::vector<Segment>& path, int n, const VecX& v, const VecX& a, double dt, double h,
                          const std::vector<double>& margin, std::vector<int>& sample_seg) {
  // Grid: segment boundaries are grid points (the profile may need to change there).
  std::vector<double> s_grid;
  std::vector<int> seg_of;
  double total = 0;
  for (size_t k = 0; k < path.size(); ++k) {
    // Blends curve sharply: a 10x finer grid there keeps the per-cell discretization small.
    const double hk = path[k].arc ? h / 10 : h;
    const int m = std::max(1, static_cast<int>(std::ceil(path[k].length / hk)));
    for (int j = 0; j < m; ++j) {
      s_grid.push_back(total + path[k].length * j / m);
      seg_of.push_back(static_cast<int>(k));
    }
    total += path[k].length;
  }
  s_grid.push_back(total);
  seg_of.push_back(static_cast<int>(path.size()) - 1);
  std::vector<double> seg_start(path.size() + 1, 0.0);
  for (size_t k = 0; k < path.size(); ++k) seg_start[k + 1] = seg_start[k] + path[k].length;
  const size_t N = s_grid.size();
  VecX q(n), dq(n), ddq(n);
  std::vector<VecX> DQ(N), DDQ(N);
  std::vector<double> cap(N);
  for (size_t k = 0; k < N; ++k) {
    const int sg = seg_of[k];
    path[sg].eval(s_grid[k] - seg_start[sg], q, dq, ddq);
    DQ[k] = dq, DDQ[k] = ddq;
    cap[k] = maxX(dq, ddq, v * margin[sg], a * margin[sg]);
  }
  // A corner kept sharp (no blend) is a stop: the direction jumps there.
  for (size_t k = 1; k + 1 < N; ++k)
    if (seg_of[k] != seg_of[k - 1] && !path[seg_of[k]].arc && !path[seg_of[k - 1]].arc) cap[k] = 0;
  // Forward at the largest feasible path acceleration, then backward at the smallest:
  // x = sdot^2, dx/ds = 2 sddot, each cell feasible at both ends.
  std::vector<double> x(N, 0.0);
  std::vector<std::pair<double, double>> cd;
  for (size_t k = 0; k + 1 < N; ++k) {
    const double hs = s_grid[k + 1] - s_grid[k];
    const VecX ak = a * std::min(margin[seg_of[k]], margin[seg_of[k + 1]]);
    x[k + 1] = forwardStep(x[k], DQ[k], DDQ[k], DQ[k + 1], DDQ[k + 1], hs, ak, cap[k + 1], cd);
  }
  x[N - 1] = 0;
  for (size_t k = N - 1; k-- > 0;) {
    const double hs = s_grid[k + 1] - s_grid[k];
    const VecX ak = a * std::min(margin[seg_of[k]], margin[seg_of[k + 1]]);
    x[k] = std::min(x[k], backwardStep(x[k + 1], DQ[k], DDQ[k], DQ[k + 1], DDQ[k + 1], hs, ak, cap[k], cd));
  }
  // Time at each grid point (constant sddot per cell), then samples every dt.
  std::vector<double> t(N, 0.0);
  for (size_t k = 0; k + 1 < N; ++k) {
    const double v0 = std::sqrt(std::max(0.0, x[k])), v1 = std::sqrt(std::max(0.0, x[k + 1]));
    const double hs = s_grid[k + 1] - s_grid[k];
    t[k + 1] = t[k] + (v0 + v1 > 1e-12 ? 2 * hs / (v0 + v1) : 0.0);
  }
  const int steps = static_cast<int>(std::ceil(t[N - 1] / dt - 1e-9));
  JointTrajectory out;
  out.dt = dt;
  out.q.resize(n, steps + 1);
  out.qd.resize(n, steps + 1);
  out.qdd.resize(n, steps + 1);
  sample_seg.assign(steps + 1, 0);
  size_t k = 0;
  for (int st = 0; st <= steps; ++st) {
    const double tt = std::min(st * dt, t[N - 1]);
    while (k + 2 < N && t[k + 1] <= tt) ++k;
    const double v0 = std::sqrt(std::max(0.0, x[k])), v1 = std::sqrt(std::max(0.0, x[k + 1]));
    const double hs = s_grid[k + 1] - s_grid[k];
    const double acc = (x[k + 1] - x[k]) / (2 * hs);
    const double tau = tt - t[k];
    double s = s_grid[k] + v0 * tau + 0.5 * acc * tau * tau;
    double sd = v0 + acc * tau;
    s = std::clamp(s, s_grid[k], s_grid[k + 1]);
    sd = std::clamp(sd, std::min(v0, v1), std::max(v0, v1));
    if (st == steps) s = s_grid[N - 1], sd = 0;
    int sg = seg_of[k];
    while (sg + 1 < static_cast<int>(path.size()) && s > seg_start[sg + 1]) ++sg;
    path[sg].eval(std::clamp(s - seg_start[sg], 0.0, path[sg].length), q, dq, ddq);
    sample_seg[st] = sg;
    out.q.col(st) = q;
    out.qd.col(st) = dq * sd;
    out.qdd.col(st) = dq * (st == steps ? 0.0 : acc) + ddq * sd * sd;
  }
  return out;
}

}  // namespace

JointTrajectory totgTrajectory(const std::vector<VecX>& wp, const RobotModel& robot, const LimitScaling& scale, double dt,
                               const TotgOptions& o) {
  MM_DEMAND(!wp.empty() && dt > 0);
  const int n = robot.dof();
  // Drop repeated waypoints.
  std::vector<VecX> w{wp[0]};
  for (size_t i = 1; i < wp.size(); ++i)
    if ((wp[i] - w.back()).norm() > 1e-9) w.push_back(wp[i]);
  if (w.size() == 1) {
    JointTrajectory t;
    t.dt = dt;
    t.q = w[0];
    t.qd = t.qdd = Eigen::MatrixXd::Zero(n, 1);
    return t;
  }
  const std::vector<Segment> path = blendedPath(w, o.max_deviation);
  // Discretization and sampling can overstep the limits slightly: verify, and tighten the limits
  // on the path segments where a sample oversteps them (and their neighbours), then retry.
  std::vector<double> margin(path.size(), 1.0);
  std::vector<int> sample_seg;
  const VecX v = robot.vmax() * scale.velocity, a = robot.amax() * scale.acceleration;
  for (int attempt = 0; attempt < 12; ++attempt) {
    JointTrajectory t = integrate(path, n, v, a, dt, o.grid, margin, sample_seg);
    for (int k = 0; k < t.size(); ++k)
      if (!robot.withinLimits(t.q.col(k))) return {};  // a blend leaves the joint range: tightening would not help
    // Measured both ways the controller sees them: the analytic values it is fed and the finite
    // differences of the positions it tracks.
    JointTrajectory fd = t;
    differentiate(fd);
    std::vector<double> worst(path.size(), 0.0);
    for (int k = 0; k < t.size(); ++k) {
      const double r = std::max({(t.qd.col(k).cwiseAbs().cwiseQuotient(v)).maxCoeff(), (t.qdd.col(k).cwiseAbs().cwiseQuotient(a)).maxCoeff(),
                                 (fd.qd.col(k).cwiseAbs().cwiseQuotient(v)).maxCoeff(), (fd.qdd.col(k).cwiseAbs().cwiseQuotient(a)).maxCoeff()});
      for (int nb = std::max(0, k - 1); nb <= std::min(t.size() - 1, k + 1); ++nb)
        worst[sample_seg[nb]] = std::max(worst[sample_seg[nb]], r);
    }
    bool ok = true;
    for (size_t sg = 0; sg < path.size(); ++sg)
      if (worst[sg] > 1.0 + 1e-6) {
        ok = false;
        margin[sg] *= std::min(0.995, 1.0 / worst[sg]);
      }
    if (ok) return t;
  }
  return {};
}

}  // namespace mm
