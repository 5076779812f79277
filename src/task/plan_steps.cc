#include "task/plan_steps.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "planning/blend.h"
#include "planning/chomp.h"
#include "planning/time_parameterization.h"
#include "sim/hardware.h"

namespace mm {

VecX endOf(const JointTrajectory& t) { return t.q.col(t.size() - 1); }
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

Obstacle boxOf(const ObjectState& o) {
  Obstacle b;
  b.type = o.shape == ObjectShape::kCylinder ? Obstacle::Type::kCylinder : Obstacle::Type::kBox;
  b.size = o.shape == ObjectShape::kCylinder ? Vec3(o.half_size.x(), o.half_size.z(), 0) : o.half_size;
  b.T_world = o.T_world_object;
  b.name = o.name;
  return b;
}

std::vector<Obstacle> obstaclesOf(const ObjectState& o) {
  if (o.shape != ObjectShape::kMesh || !o.pieces) return {boxOf(o)};
  std::vector<Obstacle> out;
  for (const ConvexPiece& piece : *o.pieces) {
    const PieceBox pb = pieceBox(piece);
    Obstacle b;
    b.size = pb.half;
    b.T_world = o.T_world_object * pb.T_object_box;
    b.name = o.name;
    out.push_back(b);
  }
  return out;
}

bool picked(const TrialContext& ctx, int index) {
  return std::find(ctx.picked.begin(), ctx.picked.end(), index) != ctx.picked.end();
}

PlanningScene planningScene(const TrialContext& ctx, int exclude, bool attached) {
  PlanningScene s;
  s.obstacles = ctx.statics;
  s.obstacles.insert(s.obstacles.end(), ctx.seen_obstacles.begin(), ctx.seen_obstacles.end());
  for (const ObjectState& o : ctx.objects)
    if (o.index != exclude && !picked(ctx, o.index))
      for (const Obstacle& b : obstaclesOf(o)) s.obstacles.push_back(b);
  for (const PickRecord& p : ctx.out.picks)
    if (p.at_target && p.object != exclude) {
      ObjectState placed;
      placed.index = p.object;
      placed.name = "placed_" + std::to_string(p.object);
      placed.half_size = p.half_size;
      placed.T_world_object = p.T_world_target;
      if (p.pieces) placed.shape = ObjectShape::kMesh, placed.pieces = p.pieces;
      for (const Obstacle& b : obstaclesOf(placed)) s.obstacles.push_back(b);
    }
  if (attached && ctx.held >= 0) {
    attachObject(s, ctx.held_record.half_size, ctx.T_tcp_held, ctx.held_pieces);
    // A grasp from the points closes across any direction of the object: the fingers are where
    // they closed, not at its box's y.
    const bool cloud = (ctx.held_record.grasp_type == graspTypeName(GraspType::kCloud) ||
                        ctx.held_record.grasp_type == graspTypeName(GraspType::kExternal)) &&
                       ctx.held_record.grasp_opening > 0;
    s.finger_opening = cloud ? ctx.held_record.grasp_opening : ctx.held_record.half_size.y();
  }
  return s;
}

std::vector<Obstacle> wallPaddedStatics(const TrialContext& ctx, double padding) {
  std::vector<Obstacle> out = ctx.statics;
  const double grow = ctx.options.wall_padding - padding;
  if (!(grow > 0)) return out;
  for (Obstacle& b : out) {
    const Mat3& R = b.T_world.linear();
    constexpr double kLevel = 0.17;  // an axis within 10 degrees of level is a side's normal
    if (b.type == Obstacle::Type::kBox) {
      for (int k = 0; k < 3; ++k)
        if (std::abs(R(2, k)) < kLevel) b.size[k] += grow;
    } else if (b.type != Obstacle::Type::kSphere && std::abs(R(2, 2)) > std::sqrt(1 - kLevel * kLevel)) {
      b.size.x() += grow;  // an upright cylinder's or capsule's radius
    }
  }
  return out;
}

std::unique_ptr<CollisionChecker> wallPaddedChecker(const TrialContext& ctx, PlanningScene scene, double padding) {
  if (ctx.options.wall_padding > padding) {
    const std::vector<Obstacle> grown = wallPaddedStatics(ctx, padding);
    for (size_t i = 0; i < grown.size(); ++i) {
      MM_DEMAND(scene.obstacles.at(i).name == grown[i].name);
      scene.obstacles[i] = grown[i];
    }
  }
  return makeChecker(ctx.options.checker, ctx.robot, scene, padding);
}

IkFunction ikNear(TrialContext& ctx, Rng& rng) {
  return [&ctx, &rng](const Pose& T, const VecX& seed, VecX& q) {
    IkRequest one = ctx.options.ik;
    one.target = T;
    one.seed = seed;
    one.max_attempts = 1;  // a single descent from the seed: stay on its branch
    one.limit_margin = 0.0;
    // Converged far below the control period's resolution: samples 2 ms apart are differentiated
    // twice, so IK noise of 1e-5 rad would read as accelerations of several rad/s^2.
    one.tol_position = 1e-10;
    one.tol_rotation = 1e-9;
    const IkResult r = ctx.ik_near->solve(one, rng);
    if (r.ok()) q = r.q();
    return r.ok();
  };
}
IkFunction ikNear(TrialContext& ctx) { return ikNear(ctx, ctx.rng_ik); }

IkResult ikFar(TrialContext& ctx, const Pose& T, const VecX& seed, Rng& rng, std::function<bool(const VecX&)> valid) {
  IkRequest req = ctx.options.ik;
  req.target = T;
  req.seed = seed;
  req.valid = std::move(valid);
  req.limit_margin = kLimitMargin;
  req.nearest = true;  // the least joint motion from where the arm will be
  return ctx.ik->solve(req, rng);
}
IkResult ikFar(TrialContext& ctx, const Pose& T, const VecX& seed) { return ikFar(ctx, T, seed, ctx.rng_ik); }

Failure connect(TrialContext& ctx, const std::string& stage, CollisionChecker& checker, const PlanningScene& scene,
                const VecX& start, const VecX& goal, JointTrajectory& out) {
  if (ctx.faults && ctx.faults->failPlanning(ctx, stage))
    return {stage, FailureKind::kPlanning, "planner " + ctx.options.planner.planner + ": no solution (injected fault)"};
  PlanResult r = planJointPath(ctx.robot, checker, start, goal, ctx.rng_plan.next(), ctx.options.planner);
  if (ctx.options.optimizer == "chomp" && r.ok) r.path = chompSmooth(ctx.robot, scene, checker, r.path).path;
  if (!r.ok) return {stage, r.kind, r.reason};
  TimedPath t = timeParameterize(ctx.options.time_parameterization, r.path, ctx.robot, ctx.options.scaling,
                                 ctx.hw.period(), [&](const VecX& q) { return checker.isValid(q); });
  if (t.trajectory.empty()) return {stage, FailureKind::kTimeParameterization, t.failure};
  out = std::move(t.trajectory);
  ctx.milestone("plan:" + stage);
  return {};
}

JointTrajectory blendIntoLine(TrialContext& ctx, JointTrajectory& connect, JointTrajectory& line, CollisionChecker& checker) {
  const TaskOptions& o = ctx.options;
  if (o.blend_radius <= 0 || o.settle_every_move) return {};
  JointTrajectory whole = connect;
  const long checks = checker.checks();
  const int k = blendJunction(connect, line, ctx.robot, {o.blend_radius, o.scaling}, [&](const VecX& q) { return checker.isValid(q); });
  ctx.out.collision_checks += checker.checks() - checks;
  return k > 0 ? whole : JointTrajectory{};
}

PlanStep trajectoryStep(const std::string& stage, JointTrajectory t, double opening, bool holding) {
  PlanStep s;
  s.kind = PlanStep::Kind::kTrajectory;
  s.stage = stage;
  s.trajectory = std::move(t);
  s.opening = opening;
  s.holding = holding;
  return s;
}

PlanStep gripperStep(const std::string& stage, const VecX& q_hold, double opening) {
  PlanStep s;
  s.kind = PlanStep::Kind::kGripper;
  s.stage = stage;
  s.q_hold = q_hold;
  s.opening = opening;
  return s;
}

PlanStep markerStep(const std::string& stage, PlanStep::Kind kind) {
  PlanStep s;
  s.kind = kind;
  s.stage = stage;
  return s;
}

}  // namespace mm
