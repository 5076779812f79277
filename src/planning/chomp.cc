#include "planning/chomp.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "planning/planner.h"

namespace mm {

const std::vector<std::string>& optimizerNames() {
  static const std::vector<std::string> names = {"none", "chomp"};
  return names;
}
namespace {

// The path resampled at equal joint-space arc length: m interior points plus the two ends.
std::vector<VecX> resample(const std::vector<VecX>& path, int m) {
  std::vector<double> cum{0.0};
  for (size_t k = 1; k < path.size(); ++k) cum.push_back(cum.back() + (path[k] - path[k - 1]).norm());
  std::vector<VecX> out;
  size_t seg = 0;
  for (int i = 0; i <= m + 1; ++i) {
    const double s = cum.back() * i / (m + 1);
    while (seg + 2 < path.size() && cum[seg + 1] < s) ++seg;
    const double len = cum[seg + 1] - cum[seg];
    const double f = len > 0 ? std::clamp((s - cum[seg]) / len, 0.0, 1.0) : 0.0;
    out.push_back(path[seg] + f * (path[seg + 1] - path[seg]));
  }
  out.front() = path.front();
  out.back() = path.back();
  return out;
}

// CHOMP's obstacle potential of a signed distance d with margin eps (smooth hinge).
double potential(double d, double eps, double& dc) {
  if (d < 0) {
    dc = -1;
    return -d + 0.5 * eps;
  }
  if (d < eps) {
    dc = (d - eps) / eps;
    return 0.5 * (d - eps) * (d - eps) / eps;
  }
  dc = 0;
  return 0;
}

struct Evaluator {
  const RobotModel& robot;
  const PlanningScene& scene;
  SphereModel spheres;
  double eps;
  std::vector<Pose> T, F;
  // Obstacle cost of configuration q and its gradient (dim dof); min signed distance out.
  double cost(const VecX& q, VecX& grad, double& min_d) {
    robot.linkPoses(q, scene.finger_opening, T);
    robot.frames(q, F);
    grad.setZero(robot.dof());
    double c = 0;
    min_d = INFINITY;
    for (size_t i = 0; i < spheres.local.size(); ++i) {
      const int l = spheres.link[i];
      const int frame = robot.links()[l].frame;
      if (frame == 0) continue;  // the base does not move
      const Vec3 p = T[l] * spheres.local[i];
      Vec3 g;
      const double d = sphereSceneDistance(scene, p, spheres.radius[i], g);
      min_d = std::min(min_d, d);
      double dc;
      c += potential(d, eps, dc);
      if (dc == 0) continue;
      // d(cost)/dq_j = dc * g . (z_j x (p - o_j)) for the joints before the sphere's frame.
      for (int j = 0; j < frame; ++j) {
        const Vec3 z = F[j + 1].linear() * robot.jointAxis(j);
        grad[j] += dc * g.dot(z.cross(p - F[j + 1].translation()));
      }
    }
    return c;
  }
};

// Solves A x = b for the smoothness metric A = tridiag(-1, 2, -1) (velocity finite differences
// with fixed ends), one joint column at a time (Thomas algorithm).
void solveMetric(std::vector<VecX>& b) {
  const int m = static_cast<int>(b.size());
  if (m == 0) return;
  std::vector<double> cp(m);
  std::vector<VecX> dp(m);
  cp[0] = -1.0 / 2.0;
  dp[0] = b[0] / 2.0;
  for (int i = 1; i < m; ++i) {
    const double denom = 2.0 + cp[i - 1];
    cp[i] = -1.0 / denom;
    dp[i] = (b[i] + dp[i - 1]) / denom;
  }
  b[m - 1] = dp[m - 1];
  for (int i = m - 2; i >= 0; --i) b[i] = dp[i] - cp[i] * b[i + 1];
}

// Douglas-Peucker on [a, b]: keep the farthest point from the chord if it deviates more than tol,
// or if the chord itself is not collision-free; recurse on both halves.
void reduce(const std::vector<VecX>& x, int a, int b, double tol, CollisionChecker& checker, double res,
            std::vector<int>& keep) {
  if (b - a < 2) return;
  const VecX chord = x[b] - x[a];
  const double len2 = chord.squaredNorm();
  int far = -1;
  double worst = 0;
  for (int i = a + 1; i < b; ++i) {
    const double t = len2 > 0 ? std::clamp((x[i] - x[a]).dot(chord) / len2, 0.0, 1.0) : 0.0;
    const double d = (x[i] - (x[a] + t * chord)).norm();
    if (d > worst) worst = d, far = i;
  }
  if (worst <= tol && segmentValid(checker, x[a], x[b], res)) return;
  keep.push_back(far);
  reduce(x, a, far, tol, checker, res, keep);
  reduce(x, far, b, tol, checker, res, keep);
}

}  // namespace

ChompResult chompSmooth(const RobotModel& robot, const PlanningScene& scene, CollisionChecker& checker,
                        const std::vector<VecX>& path, const ChompOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  ChompResult r;
  r.path = path;
  if (path.size() < 2) return r;
  Evaluator ev{robot, scene, coverRobot(robot, 0.0), o.clearance, {}, {}};
  std::vector<VecX> xi = resample(path, o.waypoints);
  const int m = o.waypoints;
  VecX g(robot.dof());
  auto total = [&](const std::vector<VecX>& x, double& min_d) {
    double smooth = 0, obs = 0, dmin = INFINITY;
    for (int i = 1; i <= m + 1; ++i) smooth += 0.5 * (x[i] - x[i - 1]).squaredNorm();
    for (int i = 1; i <= m; ++i) smooth += 0.5 * o.acceleration_weight * (m + 1) * (x[i + 1] - 2 * x[i] + x[i - 1]).squaredNorm();
    for (int i = 1; i <= m; ++i) {
      double d;
      obs += ev.cost(x[i], g, d);
      dmin = std::min(dmin, d);
    }
    min_d = dmin;
    return smooth * (m + 1) + o.obstacle_weight * obs;  // smoothness scaled to the path's sampling
  };
  double dmin_before;
  r.cost_before = total(xi, dmin_before);
  r.min_clearance_before = dmin_before;
  std::vector<VecX> grad(m, VecX::Zero(robot.dof()));
  double current = r.cost_before, step = o.step;
  for (int it = 0; it < o.iterations && step > 1e-6; ++it) {
    for (int i = 1; i <= m; ++i) {
      double d;
      ev.cost(xi[i], g, d);
      // Smoothness gradient in the same scale as the cost: velocity term (second difference) and
      // acceleration term (fourth difference; the ends' neighbours use the fixed ends).
      VecX smooth = (2 * xi[i] - xi[i - 1] - xi[i + 1]) * (m + 1);
      auto acc = [&](int k) -> VecX { return xi[k + 1] - 2 * xi[k] + xi[k - 1]; };
      VecX a4 = -2 * acc(i);
      if (i - 1 >= 1) a4 += acc(i - 1);
      if (i + 1 <= m) a4 += acc(i + 1);
      smooth += o.acceleration_weight * (m + 1) * (m + 1) * a4;
      grad[i - 1] = smooth + o.obstacle_weight * g;
    }
    solveMetric(grad);  // covariant step: A^-1 gradient
    // Backtracking: take the step only if the total cost goes down, else halve it.
    for (;;) {
      std::vector<VecX> trial = xi;
      for (int i = 1; i <= m; ++i)
        trial[i] = (xi[i] - step * grad[i - 1] / (m + 1)).cwiseMax(robot.lower()).cwiseMin(robot.upper());
      double d;
      const double c = total(trial, d);
      if (c < current) {
        xi.swap(trial);
        current = c;
        step *= 1.5;
        break;
      }
      step *= 0.5;
      if (step < 1e-6) break;
    }
  }
  double dmin_after;
  r.cost_after = total(xi, dmin_after);
  r.min_clearance_after = dmin_after;
  bool valid = r.cost_after < r.cost_before;
  for (size_t k = 1; valid && k < xi.size(); ++k) valid = segmentValid(checker, xi[k - 1], xi[k], o.resolution);
  if (valid) {
    r.improved = true;
    std::vector<int> keep{0, static_cast<int>(xi.size()) - 1};
    if (o.reduce_tolerance > 0) reduce(xi, 0, static_cast<int>(xi.size()) - 1, o.reduce_tolerance, checker, o.resolution, keep);
    else
      for (int i = 1; i + 1 < static_cast<int>(xi.size()); ++i) keep.push_back(i);
    std::sort(keep.begin(), keep.end());
    r.path.clear();
    for (int i : keep) r.path.push_back(xi[i]);
  } else {
    r.reason = r.cost_after < r.cost_before ? "optimized path failed validation" : "no improvement";
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace mm
