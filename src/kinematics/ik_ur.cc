// The analytic solver for a UR-family arm: its closed form gives up to 8 solutions; each joint
// angle is then taken at the turn (q + 2 pi k) nearest the seed's within the joint's limits (UR
// joints span +-2 pi, so one pose has up to 2^6 equivalent configurations per branch), and the
// branches are ranked by their distance to the seed. With `polish`, when no branch fits the limits,
// the branches clamped into the limits and then random starts seed the damped least squares solver.
#include <algorithm>
#include <chrono>
#include <cmath>

#include "kinematics/chain.h"
#include "kinematics/ik_solvers.h"
#include "kinematics/ur_analytic.h"

namespace mm {
namespace {

class UrSolver final : public IkSolver {
 public:
  UrSolver(const RobotModel& robot, bool polish) : robot_(robot), ik_(robot), chain_(robot), polish_(polish) {}
  std::string name() const override { return polish_ ? "hybrid" : "analytic"; }

  IkResult solve(const IkRequest& req, Rng& rng) override {
    IkResult r;
    if (!validRequest(robot_, req, r)) return r;
    const auto t0 = std::chrono::steady_clock::now();
    const VecX lo = robot_.lower().array() + req.limit_margin, hi = robot_.upper().array() - req.limit_margin;
    std::array<UrAnalyticIk::Joints, 8> sols;
    ++r.iterations;
    ++r.attempts;
    const int n = ik_.solve(req.target, req.seed[5], sols);
    std::vector<std::pair<double, VecX>> ranked;
    std::vector<VecX> near_misses;
    for (int i = 0; i < n; ++i) {
      VecX q = sols[i];
      bool fits = true;
      for (int j = 0; j < 6; ++j) {
        // The turn nearest the seed among those inside the limits.
        const double base = q[j] + 2 * M_PI * std::round((req.seed[j] - q[j]) / (2 * M_PI));
        double best = NAN;
        for (const double c : {base, base - 2 * M_PI, base + 2 * M_PI})
          if (c >= lo[j] && c <= hi[j] && (std::isnan(best) || std::abs(c - req.seed[j]) < std::abs(best - req.seed[j])))
            best = c;
        if (std::isnan(best)) {
          fits = false;
          q[j] = std::clamp(base, lo[j], hi[j]);
        } else {
          q[j] = best;
        }
      }
      if (fits) ranked.push_back({(q - req.seed).squaredNorm(), q});
      else near_misses.push_back(q);
    }
    std::stable_sort(ranked.begin(), ranked.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    for (const auto& [d, q] : ranked)
      if (addSolution(r, robot_, req, q) && static_cast<int>(r.solutions.size()) >= req.max_solutions) return r;
    if (polish_ && r.solutions.empty()) {
      descendFromStarts(robot_, chain_, req, near_misses, rng, t0, r);
      if (static_cast<int>(r.solutions.size()) >= req.max_solutions) return r;
    }
    if (r.solutions.empty()) {
      r.status = IkStatus::kNoSolution;
      r.reason = n == 0 ? "the pose is out of reach (no closed-form branch)"
                        : "none of the " + std::to_string(n) + " closed-form branches fits the joint limits" +
                              (polish_ ? " (numerical restarts failed too)" : "");
    }
    return r;
  }

 private:
  const RobotModel& robot_;
  UrAnalyticIk ik_;
  FastChain chain_;
  bool polish_;
};

}  // namespace

std::unique_ptr<IkSolver> makeUrAnalyticSolver(const RobotModel& robot, bool polish) {
  return std::make_unique<UrSolver>(robot, polish);
}

}  // namespace mm
