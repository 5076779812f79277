// The analytic solver: He & Liu's geometric solution swept over q7, outward from the seed's q7;
// the first q7 whose solutions fit the joint limits wins (or, asking for several solutions, the
// sweep goes on until enough distinct ones are found). With `polish`, a q7 sample whose solutions
// miss the limits only slightly seeds the damped least squares solver (the "hybrid").
#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/error.h"
#include "kinematics/chain.h"
#include "kinematics/ik_solvers.h"
#include "kinematics/panda_analytic.h"

namespace mm {
namespace {

class AnalyticSolver final : public IkSolver {
 public:
  AnalyticSolver(const RobotModel& robot, bool polish) : robot_(robot), ik_(robot), chain_(robot), polish_(polish) {
    // Sample fractions of the q7 range: -1 stands for the seed's q7; then levels of a dyadic
    // grid (1/2; 1/4, 3/4; 1/8, ...) down to 1/512 of the range (about 0.01 rad for the Panda).
    order_.push_back(-1);
    for (int level = 1; level <= 9; ++level)
      for (int k = 1; k < (1 << level); k += 2) order_.push_back(static_cast<double>(k) / (1 << level));
  }
  std::string name() const override { return polish_ ? "hybrid" : "analytic"; }

  IkResult solve(const IkRequest& req, Rng& rng) override {
    IkResult r;
    if (!validRequest(robot_, req, r)) return r;
    const auto t0 = std::chrono::steady_clock::now();
    const double lo7 = robot_.lower()[6] + req.limit_margin, hi7 = robot_.upper()[6] - req.limit_margin;
    const double start = std::clamp(req.seed[6], lo7, hi7);
    std::array<PandaAnalyticIk::Joints, 16> sols;
    if (req.nearest && req.max_solutions <= 1) return nearest(req, lo7, hi7);
    VecX q(7);
    std::vector<VecX> near_misses;
    for (const double f : order_) {
      if (r.iterations >= req.max_iterations) break;
      // The seed's q7 first, then coarse to fine over the range, nearest the seed first per level.
      const double q7 = f < 0 ? start : lo7 + f * (hi7 - lo7);
      ++r.iterations;
      ++r.attempts;
      const int n = ik_.solve(req.target, q7, req.seed[0], sols);
      // Closest to the seed first, so a single answer is the nearest one.
      std::array<int, 16> order;
      for (int i = 0; i < n; ++i) order[i] = i;
      std::sort(order.begin(), order.begin() + n, [&](int a, int b) {
        return (sols[a] - req.seed).cwiseAbs().maxCoeff() < (sols[b] - req.seed).cwiseAbs().maxCoeff();
      });
      for (int i = 0; i < n; ++i) {
        q = sols[order[i]];
        if (addSolution(r, robot_, req, q)) {
          if (static_cast<int>(r.solutions.size()) >= req.max_solutions) return r;
        } else if (polish_ && near_misses.size() < 16) {
          near_misses.push_back(q.cwiseMax(robot_.lower()).cwiseMin(robot_.upper()));
        }
      }
      if (!r.solutions.empty() && req.max_solutions <= 1) return r;
    }
    if (polish_ && r.solutions.empty()) {
      // Seeds from the analytic near misses, then random restarts, descended numerically.
      descendFromStarts(robot_, chain_, req, near_misses, rng, t0, r);
      if (static_cast<int>(r.solutions.size()) >= req.max_solutions) return r;
    }
    if (r.solutions.empty()) {
      r.status = IkStatus::kNoSolution;
      r.reason = "no solution within the joint limits over " + std::to_string(r.attempts) + " q7 samples" +
                 (polish_ ? " and numerical restarts" : "");
    }
    return r;
  }

 private:
  // The solution nearest the seed: q7 on a 64-sample grid, plus fine samples around the seed's own
  // q7 (its branch may be feasible only in a narrow q7 interval), then three local refinements
  // around the best q7 (spacing /8 each, down to 1.4e-4 rad for the Panda). Candidates are ranked by distance first; only the winner
  // pays for the FK check.
  IkResult nearest(const IkRequest& req, double lo7, double hi7) {
    IkResult r;
    std::array<PandaAnalyticIk::Joints, 16> sols;
    const VecX lo = robot_.lower().array() + req.limit_margin, hi = robot_.upper().array() - req.limit_margin;
    std::vector<std::pair<double, VecX>> ranked;  // (distance, q), best kept first
    double best_q7 = std::clamp(req.seed[6], lo7, hi7);
    auto sample = [&](double q7) {
      if (q7 < lo7 || q7 > hi7) return;
      ++r.iterations;
      ++r.attempts;
      const int n = ik_.solve(req.target, q7, req.seed[0], sols);
      for (int i = 0; i < n; ++i) {
        const VecX q = sols[i];
        if ((q.array() < lo.array()).any() || (q.array() > hi.array()).any()) continue;
        const double d = (q - req.seed).squaredNorm();
        if (ranked.empty() || d < ranked.front().first) {
          ranked.insert(ranked.begin(), {d, q});
          best_q7 = q7;
        } else {
          ranked.push_back({d, q});
        }
      }
    };
    const double seed_q7 = best_q7;
    const int kGrid = 64;
    double spacing = (hi7 - lo7) / kGrid;
    sample(seed_q7);
    for (int k = 1; k <= 8; ++k) {
      sample(seed_q7 + k * spacing / 8);
      sample(seed_q7 - k * spacing / 8);
    }
    for (int k = 0; k <= kGrid; ++k) sample(lo7 + k * spacing);
    for (int level = 0; level < 3 && !ranked.empty(); ++level) {
      const double center = best_q7;
      spacing /= 8;
      for (int k = -8; k <= 8; ++k)
        if (k != 0) sample(center + k * spacing);
    }
    std::stable_sort(ranked.begin(), ranked.end(), [](auto& a, auto& b) { return a.first < b.first; });
    // The nearest that passes the FK check and the request's validity; one within `distinct` of a
    // refused one is taken as refused too (the fine samples are near-copies of each other).
    std::vector<VecX> refused;
    for (const auto& [d, q] : ranked) {
      if (std::any_of(refused.begin(), refused.end(), [&](const VecX& f) { return (f - q).cwiseAbs().maxCoeff() < req.distinct; }))
        continue;
      if (addSolution(r, robot_, req, q)) break;
      refused.push_back(q);
    }
    if (r.solutions.empty()) {
      r.status = IkStatus::kNoSolution;
      r.reason = "no solution within the joint limits" + std::string(req.valid ? " that is valid" : "") + " over " +
                 std::to_string(r.attempts) + " q7 samples";
    }
    return r;
  }

  const RobotModel& robot_;
  PandaAnalyticIk ik_;
  FastChain chain_;
  bool polish_;
  std::vector<double> order_;
};

}  // namespace

std::unique_ptr<IkSolver> makeAnalyticSolver(const RobotModel& robot, bool polish) {
  const std::string& form = robot.spec().analytic_ik;
  if (form == "panda") return std::make_unique<AnalyticSolver>(robot, polish);
  if (form == "ur") return makeUrAnalyticSolver(robot, polish);
  throw InputError(robot.spec().file, std::string("the ") + (polish ? "hybrid" : "analytic") +
                                          " IK needs the robot to declare its closed form (analytic_ik: panda or ur); this one declares none");
}

}  // namespace mm
