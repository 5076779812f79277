#include "task/trial_context.h"

#include <algorithm>
#include <utility>

#include "core/error.h"
#include "sim/hardware.h"

namespace mm {

// ---- executor --------------------------------------------------------------------------------

Executor::Step Executor::step() {
  if (before_step_) before_step_();
  if (active_ && active_->running()) {
    if (!active_->command(hw_)) {
      ended();
      return Step::kEndedWithoutStep;
    }
    hw_.step();
    active_->observe(hw_);
    if (active_->running()) return Step::kStepped;
    ended();
    return Step::kEnded;
  }
  // Idle: hold the arm where it was last sent, at rest.
  const VecX q = hw_.commandedPositions(), zero = VecX::Zero(q.size());
  hw_.write(q, zero, zero);
  hw_.step();
  return Step::kStepped;
}

Motion& Executor::start(std::unique_ptr<Motion> m, std::function<void(Motion&)> on_end) {
  MM_DEMAND(!busy());
  active_ = std::move(m);
  on_end_ = std::move(on_end);
  return *active_;
}

void Executor::ended() {
  if (on_end_) std::exchange(on_end_, {})(*active_);
}

void Executor::halt() {
  if (busy()) active_->halt(hw_);
}

// ---- context ---------------------------------------------------------------------------------

TrialContext::TrialContext(Hardware& hw_, const RobotModel& robot_, const std::vector<Obstacle>& statics_,
                           const TaskOptions& task, const PerceptionOptions& perception_, uint64_t campaign_seed,
                           uint64_t trial)
    : hw(hw_), robot(robot_), statics(statics_), options(task), perception(perception_),
      rng_perception(Rng::stream(campaign_seed, trial, Purpose::kPerception)),
      rng_ik(Rng::stream(campaign_seed, trial, Purpose::kIk)),
      rng_plan(Rng::stream(campaign_seed, trial, Purpose::kPlanner)),
      rng_grasp(Rng::stream(campaign_seed, trial, Purpose::kGrasp)),
      run_seed(campaign_seed),
      trial_index(trial),
      ik(makeIkSolver(task.ik_solver, robot_)), ik_near(makeIkSolver("dls", robot_)), executor(hw_),
      t_start(hw_.time()), q_rest(hw_.jointPositions()),
      gripper_opening(robot_.spec().gripper.travel) {  // the hardware starts with the gripper commanded open
  executor.setBeforeStep([this] {
    if (faults) faults->beforeStep(*this);
  });
  // What the camera sees is what the robot knows: the simulator's truth is closed to decisions.
  if (perception.mode == PerceptionMode::kCamera) hw.guardTruth(true);
}

TrialContext::~TrialContext() { hw.guardTruth(false); }

int TrialContext::truthIndex(int id) const {
  if (perception.mode == PerceptionMode::kCamera) {
    const auto it = truth_of.find(id);
    return it == truth_of.end() ? -1 : it->second;
  }
  return id >= 0 && id < 1000 ? id : -1;  // 1000 and up: a ghost an injected false detection made
}

StageRecord& TrialContext::stage(const std::string& name) {
  out.stages.push_back({name, true, 0, 0});
  return out.stages.back();
}

Failure TrialContext::fail(const Failure& f) {
  if (f.kind == FailureKind::kHalted) {  // the tree stopped it: recorded, but not the trial's failure
    out.failures.push_back({f, simTime(), true});
    return f;
  }
  out.failure_stage = f.stage;
  out.failure_reason = f.reason;
  out.failure_kind = f.kind;
  if (f.kind == FailureKind::kSimUnstable) out.sim_unstable = true;
  if (f.kind == FailureKind::kDropped) out.dropped = true;
  if (!out.stages.empty()) out.stages.back().ok = false;
  out.failures.push_back({f, simTime(), false});
  return f;
}

const RecordedFailure* TrialContext::unhandledFailure() const {
  for (auto it = out.failures.rbegin(); it != out.failures.rend(); ++it)
    if (it->failure.kind != FailureKind::kHalted) return it->handled ? nullptr : &*it;
  return nullptr;
}

void TrialContext::actionStarted() {
  for (RecordedFailure& r : out.failures) r.handled = true;
}

double& TrialContext::computeBucket(TimeBucket b) {
  switch (b) {
    case TimeBucket::kPick: return out.plan_pick_time;
    case TimeBucket::kPlace: return out.plan_place_time;
    case TimeBucket::kHome: break;
  }
  return out.return_home_time;
}

double& TrialContext::executeBucket(TimeBucket b) {
  switch (b) {
    case TimeBucket::kPick: return out.execute_pick_time;
    case TimeBucket::kPlace: return out.execute_place_time;
    case TimeBucket::kHome: break;
  }
  return out.return_home_time;
}

double TrialContext::simTime() const { return hw.time() - t_start; }

double TrialContext::computeSoFar() const {
  double c = 0;
  for (const StageRecord& s : out.stages) c += s.compute_seconds;
  return c;
}

void TrialContext::milestone(const std::string& what) { milestones.push_back({what, simTime(), computeSoFar()}); }

bool TrialContext::senseObstacles() {
  if (perception.mode == PerceptionMode::kHardcoded || perception.mode == PerceptionMode::kCamera) return false;
  std::vector<Obstacle> now = hw.obstacles();
  auto same = [](const Obstacle& a, const Obstacle& b) {
    return a.name == b.name && (a.T_world.translation() - b.T_world.translation()).norm() < 0.01 &&
           angleBetween(a.T_world.linear(), b.T_world.linear()) < 0.05 && (a.size - b.size).norm() < 1e-3;
  };
  const bool changed = now.size() != seen_obstacles.size() ||
                       !std::equal(now.begin(), now.end(), seen_obstacles.begin(), same);
  if (changed) seen_obstacles = std::move(now);
  return changed;
}

}  // namespace mm
