// orocos-KDL based solvers.
//  - "kdl": ChainIkSolverPos_NR_JL from the seed, one attempt (100 iterations), as MoveIt's
//    default KDL plugin solves; "kdl_restarts": the same from random seeds until the budget.
//  - "trac_ik" / "trac_ik_distance": the TRAC-IK method (P. Beeson and B. Ames, "TRAC-IK: An
//    Open-Source Library for Improved Solving of Generic Inverse Kinematics", Humanoids 2015),
//    our implementation: a Newton solver on KDL's pseudo-inverse velocity solver with joint-limit
//    clamping and random restarts when it stalls, run concurrently with an SQP formulation
//    (minimize the squared pose error within the joint bounds, NLopt's SLSQP). Speed mode returns
//    the first solution; Distance mode spends the budget and returns the one nearest the seed.
//
// Determinism with two threads: both count work in the same unit (one FK + Jacobian evaluation).
// The winner is the solution found with the fewest units (ties to Newton); each thread stops as
// soon as its own count passes the best found, so the answer does not depend on scheduling while
// the wall time stays close to the first finisher's.
#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainiksolverpos_nr_jl.hpp>
#include <kdl/chainiksolvervel_pinv.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <nlopt.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <thread>

#include "kinematics/chain.h"
#include "kinematics/ik_solvers.h"

namespace mm {
namespace {

using Clock = std::chrono::steady_clock;

KDL::Frame toKdl(const Pose& T) {
  const Mat3& R = T.linear();
  const Vec3& p = T.translation();
  return KDL::Frame(KDL::Rotation(R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)),
                    KDL::Vector(p.x(), p.y(), p.z()));
}

// T_base_tcp = T_pre0 R0 T_pre1 R1 ... R_{n-1} T_tcp as KDL segments.
KDL::Chain kdlChain(const RobotModel& robot) {
  KDL::Chain chain;
  chain.addSegment(KDL::Segment("base", KDL::Joint(KDL::Joint::None), toKdl(robot.jointOrigin(0))));
  for (int k = 0; k < robot.dof(); ++k) {
    const Vec3& a = robot.jointAxis(k);
    const KDL::Frame tip = toKdl(k + 1 < robot.dof() ? robot.jointOrigin(k + 1) : robot.T_flange_tcp());
    chain.addSegment(KDL::Segment(robot.jointNames()[k],
                                  KDL::Joint(robot.jointNames()[k], KDL::Vector(0, 0, 0), KDL::Vector(a.x(), a.y(), a.z()), KDL::Joint::RotAxis),
                                  tip));
  }
  return chain;
}

KDL::JntArray toJnt(const VecX& q) {
  KDL::JntArray j(q.size());
  for (int i = 0; i < q.size(); ++i) j(i) = q[i];
  return j;
}
VecX fromJnt(const KDL::JntArray& j) {
  VecX q(j.rows());
  for (unsigned i = 0; i < j.rows(); ++i) q[i] = j(i);
  return q;
}

double seconds(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

class KdlSolver final : public IkSolver {
 public:
  KdlSolver(const RobotModel& robot, bool restarts)
      : robot_(robot), restarts_(restarts), chain_(kdlChain(robot)), fk_(chain_), vel_(chain_),
        lo_(toJnt(robot.lower())), hi_(toJnt(robot.upper())) {}
  std::string name() const override { return restarts_ ? "kdl_restarts" : "kdl"; }

  IkResult solve(const IkRequest& req, Rng& rng) override {
    IkResult r;
    if (!validRequest(robot_, req, r)) return r;
    const auto t0 = Clock::now();
    const VecX lo = robot_.lower().array() + req.limit_margin, hi = robot_.upper().array() - req.limit_margin;
    // KDL's eps bounds each twist component; 1/2 of the tolerance keeps the norms within it.
    KDL::ChainIkSolverPos_NR_JL ik(chain_, toJnt(lo), toJnt(hi), fk_, vel_, kIterations, 0.5 * std::min(req.tol_position, req.tol_rotation));
    const KDL::Frame target = toKdl(req.target);
    KDL::JntArray out(robot_.dof());
    VecX q(robot_.dof());
    const int attempts = restarts_ ? req.max_attempts : 1;
    while (r.attempts < attempts && r.iterations < req.max_iterations) {
      if (r.attempts == 0) q = req.seed.cwiseMax(lo).cwiseMin(hi);
      else
        for (int i = 0; i < robot_.dof(); ++i) q[i] = rng.uniform(lo[i], hi[i]);
      ++r.attempts;
      const int rc = ik.CartToJnt(toJnt(q), target, out);
      r.iterations += kIterations;  // KDL does not report how many it used; count the cap
      if (rc >= 0 && addSolution(r, robot_, req, fromJnt(out)) && static_cast<int>(r.solutions.size()) >= req.max_solutions)
        return r;
      if (seconds(t0) > req.time_cap) {
        r.hit_time_cap = true;
        break;
      }
    }
    if (r.solutions.empty()) {
      r.status = IkStatus::kNoSolution;
      r.reason = "KDL NR_JL found no solution in " + std::to_string(r.attempts) + " attempt(s)";
    }
    return r;
  }

 private:
  static constexpr int kIterations = 100;
  const RobotModel& robot_;
  bool restarts_;
  KDL::Chain chain_;
  KDL::ChainFkSolverPos_recursive fk_;
  KDL::ChainIkSolverVel_pinv vel_;
  KDL::JntArray lo_, hi_;
};

// ---- TRAC-IK --------------------------------------------------------------------------------

struct Race {
  std::mutex mu;
  std::atomic<long> best_units{std::numeric_limits<long>::max()};
  int best_prio = 2;
  VecX best_q;
  std::vector<std::pair<long, VecX>> found;  // distance mode: every solution, with its units
  // True when (units, prio) is not better than the best so far: the thread can stop.
  bool beaten(long units, int prio) const {
    const long b = best_units.load(std::memory_order_relaxed);
    return units > b || (units == b && prio >= best_prio);
  }
  void offer(long units, int prio, const VecX& q, bool distance) {
    std::lock_guard<std::mutex> lock(mu);
    if (distance) found.push_back({units * 2 + prio, q});
    if (units < best_units || (units == best_units && prio < best_prio)) {
      best_units = units;
      best_prio = prio;
      best_q = q;
    }
  }
};

class TracIkSolver final : public IkSolver {
 public:
  TracIkSolver(const RobotModel& robot, bool distance)
      : robot_(robot), distance_(distance), chain_(kdlChain(robot)), fast_(robot) {}
  std::string name() const override { return distance_ ? "trac_ik_distance" : "trac_ik"; }
  int threads() const override { return 2; }

  IkResult solve(const IkRequest& req, Rng& rng) override {
    IkResult r;
    r.threads = 2;
    if (!validRequest(robot_, req, r)) return r;
    const auto t0 = Clock::now();
    Race race;
    // Each thread draws its restarts from its own stream, split off deterministically.
    const uint64_t s_newton = rng.next(), s_sqp = rng.next();
    const long budget = req.max_iterations / 2;  // per thread
    long units_newton = 0, units_sqp = 0;
    int attempts_newton = 0, attempts_sqp = 0;
    std::atomic<bool> capped{false};
    std::thread sqp([&] { runSqp(req, Rng(s_sqp), race, budget, t0, units_sqp, attempts_sqp, capped); });
    runNewton(req, Rng(s_newton), race, budget, t0, units_newton, attempts_newton, capped);
    sqp.join();
    r.iterations = units_newton + units_sqp;
    r.attempts = attempts_newton + attempts_sqp;
    r.hit_time_cap = capped;
    if (distance_) {
      std::sort(race.found.begin(), race.found.end(), [](auto& a, auto& b) { return a.first < b.first; });
      std::vector<VecX> qs;
      for (auto& f : race.found) qs.push_back(f.second);
      std::stable_sort(qs.begin(), qs.end(), [&](const VecX& a, const VecX& b) {
        return (a - req.seed).squaredNorm() < (b - req.seed).squaredNorm();
      });
      for (const VecX& q : qs) addSolution(r, robot_, req, q);
    } else if (race.best_q.size()) {
      addSolution(r, robot_, req, race.best_q);
    }
    if (r.solutions.empty()) {
      r.status = IkStatus::kNoSolution;
      r.reason = "TRAC-IK found no solution in " + std::to_string(r.iterations) + " units";
    }
    return r;
  }

 private:
  bool stop(Race& race, long units, int prio, long budget, Clock::time_point t0, std::atomic<bool>& capped,
            const IkRequest& req) const {
    if (units >= budget) return true;
    if (!distance_ && race.beaten(units, prio)) return true;
    if ((units & 15) == 0 && seconds(t0) > req.time_cap) {
      capped = true;
      return true;
    }
    return capped.load(std::memory_order_relaxed);
  }

  bool converged(const KDL::Twist& d, const IkRequest& req) const {
    return std::sqrt(d.vel.x() * d.vel.x() + d.vel.y() * d.vel.y() + d.vel.z() * d.vel.z()) < 0.5 * req.tol_position &&
           std::sqrt(d.rot.x() * d.rot.x() + d.rot.y() * d.rot.y() + d.rot.z() * d.rot.z()) < 0.5 * req.tol_rotation;
  }

  // Newton-Raphson on KDL's pseudo-inverse, clamped to the limits, restarting when it stalls.
  void runNewton(const IkRequest& req, Rng rng, Race& race, long budget, Clock::time_point t0, long& units,
                 int& attempts, std::atomic<bool>& capped) const {
    // KDL::Joint caches its last pose in mutable members: each thread needs its own chain.
    const KDL::Chain chain = chain_;
    KDL::ChainFkSolverPos_recursive fk(chain);
    KDL::ChainIkSolverVel_pinv vel(chain);
    const int n = robot_.dof();
    const VecX lo = robot_.lower().array() + req.limit_margin, hi = robot_.upper().array() - req.limit_margin;
    const KDL::Frame target = toKdl(req.target);
    KDL::JntArray q(n), dq(n);
    KDL::Frame f;
    VecX v(n);
    while (!stop(race, units, 0, budget, t0, capped, req)) {
      ++attempts;
      v = attempts == 1 ? VecX(req.seed.cwiseMax(lo).cwiseMin(hi)) : VecX(n);
      if (attempts > 1)
        for (int i = 0; i < n; ++i) v[i] = rng.uniform(lo[i], hi[i]);
      q = toJnt(v);
      for (int it = 0; it < 100 && !stop(race, units, 0, budget, t0, capped, req); ++it) {
        ++units;
        fk.JntToCart(q, f);
        const KDL::Twist d = KDL::diff(f, target);
        if (converged(d, req)) {
          race.offer(units, 0, fromJnt(q), distance_);
          break;
        }
        vel.CartToJnt(q, d, dq);
        double step = 0;
        for (int i = 0; i < n; ++i) {
          const double nq = std::clamp(q(i) + dq(i), lo[i], hi[i]);
          step = std::max(step, std::abs(nq - q(i)));
          q(i) = nq;
        }
        if (step < 1e-9) break;  // stuck at a limit or a local minimum: restart
      }
    }
  }

  // SQP: minimize 0.5 |e(q)|^2 within the bounds with SLSQP; restarts from random seeds.
  void runSqp(const IkRequest& req, Rng rng, Race& race, long budget, Clock::time_point t0, long& units, int& attempts,
              std::atomic<bool>& capped) const {
    const int n = robot_.dof();
    const VecX lo = robot_.lower().array() + req.limit_margin, hi = robot_.upper().array() - req.limit_margin;
    const KDL::Chain chain = chain_;  // a private copy: KDL::Joint's pose cache is not thread-safe
    KDL::ChainFkSolverPos_recursive fk(chain);
    KDL::ChainJntToJacSolver jac(chain);
    const KDL::Frame target = toKdl(req.target);
    struct Ctx {
      const TracIkSolver* self;
      const IkRequest* req;
      Race* race;
      long* units;
      long budget;
      Clock::time_point t0;
      std::atomic<bool>* capped;
      KDL::ChainFkSolverPos_recursive* fk;
      KDL::ChainJntToJacSolver* jac;
      const KDL::Frame* target;
      bool done = false;
      std::vector<double> solution;
    } ctx{this, &req, &race, &units, budget, t0, &capped, &fk, &jac, &target, false, {}};
    auto objective = [](const std::vector<double>& x, std::vector<double>& grad, void* data) -> double {
      Ctx& c = *static_cast<Ctx*>(data);
      if (c.self->stop(*c.race, *c.units, 1, c.budget, c.t0, *c.capped, *c.req)) throw nlopt::forced_stop();
      ++*c.units;
      const int dof = static_cast<int>(x.size());
      KDL::JntArray q(dof);
      for (int i = 0; i < dof; ++i) q(i) = x[i];
      KDL::Frame f;
      c.fk->JntToCart(q, f);
      const KDL::Twist d = KDL::diff(f, *c.target);
      if (c.self->converged(d, *c.req)) {
        c.done = true;
        c.solution = x;
        throw nlopt::forced_stop();
      }
      if (!grad.empty()) {
        KDL::Jacobian J(dof);
        c.jac->JntToJac(q, J);
        for (int i = 0; i < dof; ++i) {
          grad[i] = 0;
          for (int k = 0; k < 6; ++k) grad[i] -= J(k, i) * d(k);
        }
      }
      double e = 0;
      for (int k = 0; k < 6; ++k) e += d(k) * d(k);
      return 0.5 * e;
    };
    std::vector<double> x(n), vlo(lo.data(), lo.data() + n), vhi(hi.data(), hi.data() + n);
    while (!stop(race, units, 1, budget, t0, capped, req)) {
      ++attempts;
      for (int i = 0; i < n; ++i) x[i] = attempts == 1 ? std::clamp(req.seed[i], lo[i], hi[i]) : rng.uniform(lo[i], hi[i]);
      nlopt::opt opt(nlopt::LD_SLSQP, n);
      opt.set_lower_bounds(vlo);
      opt.set_upper_bounds(vhi);
      opt.set_min_objective(objective, &ctx);
      opt.set_xtol_abs(1e-12);
      opt.set_maxeval(200);
      double fval;
      ctx.done = false;
      try {
        opt.optimize(x, fval);
      } catch (const nlopt::forced_stop&) {
      } catch (const std::exception&) {
        // SLSQP gives up (roundoff, bad step): restart from another seed.
      }
      if (ctx.done) race.offer(units, 1, Eigen::Map<const VecX>(ctx.solution.data(), n), distance_);
    }
  }

  const RobotModel& robot_;
  bool distance_;
  KDL::Chain chain_;
  FastChain fast_;
};

}  // namespace

Pose kdlForwardKinematics(const RobotModel& robot, const VecX& q) {
  const KDL::Chain chain = kdlChain(robot);
  KDL::ChainFkSolverPos_recursive fk(chain);
  KDL::Frame f;
  fk.JntToCart(toJnt(q), f);
  Mat3 R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = f.M(r, c);
  return makePose(Vec3(f.p.x(), f.p.y(), f.p.z()), R);
}

std::unique_ptr<IkSolver> makeKdlSolver(const RobotModel& robot, bool restarts) {
  return std::make_unique<KdlSolver>(robot, restarts);
}
std::unique_ptr<IkSolver> makeTracIkSolver(const RobotModel& robot, bool distance) {
  return std::make_unique<TracIkSolver>(robot, distance);
}

}  // namespace mm
