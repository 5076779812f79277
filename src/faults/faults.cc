#include "faults/faults.h"

#include <algorithm>
#include <cmath>

#include "planning/collision.h"
#include "sim/sim_world.h"
#include "task/trial_context.h"

namespace mm {

const char* faultKindName(FaultKind k) {
  switch (k) {
    case FaultKind::kPerceptionDropout: return "perception_dropout";
    case FaultKind::kPerceptionPoseError: return "perception_pose_error";
    case FaultKind::kFalseDetection: return "false_detection";
    case FaultKind::kPlanningFailure: return "planning_failure";
    case FaultKind::kObstacleAdded: return "obstacle_added";
    case FaultKind::kObjectRemoved: return "object_removed";
    case FaultKind::kObjectMoved: return "object_moved";
    case FaultKind::kGraspSlip: return "grasp_slip";
    case FaultKind::kGripperNoClose: return "gripper_no_close";
    case FaultKind::kJointStall: return "joint_stall";
    case FaultKind::kCameraBlackout: return "camera_blackout";
    case FaultKind::kDepthDropout: return "depth_dropout";
    case FaultKind::kExtrinsicsDrift: return "extrinsics_drift";
    case FaultKind::kCount: break;
  }
  return "?";
}

bool faultRecoverable(FaultKind k) { return k != FaultKind::kObjectRemoved; }

bool faultNeedsCamera(FaultKind k) {
  return k == FaultKind::kCameraBlackout || k == FaultKind::kDepthDropout || k == FaultKind::kExtrinsicsDrift;
}

FaultKind faultKindFromName(const std::string& name) {
  for (int k = 0; k < static_cast<int>(FaultKind::kCount); ++k)
    if (name == faultKindName(static_cast<FaultKind>(k))) return static_cast<FaultKind>(k);
  return FaultKind::kCount;
}

void FaultOptions::declare(ConfigArchive& a) {
  const char* what[] = {
      "probability per trial that the first perception sees nothing (sensor dropout)",
      "probability per trial that the first perception reports the target shifted by pose_error and turned by pose_error_yaw",
      "probability per trial that the first perception reports a phantom object at a free spot of the bin where the robot goes for it first (a bin too full for such a spot gets none)",
      "probability per trial that the first joint-space planning call fails",
      "probability per trial that an obstacle (the scene's obstacle_0) appears in the way of the place's transit just planned: the robot learns of it by sensing while it moves",
      "probability per trial that the target leaves the bin while the arm moves to it (no action can pick it: noticing and moving on is correct)",
      "probability per trial that the target is pushed move_distance aside while the arm moves to it",
      "probability per trial that the held object slips out of the fingers as it is lifted out of the bin (it falls back in: detect, pick again)",
      "probability per trial that the gripper does not close when first told to",
      "probability per trial that the fastest-moving joint stalls for stall_time during a move",
      "camera mode: probability per trial that the first frame is black, with no depth (the camera blacks out once)",
      "camera mode: probability per trial that the first frame has no depth over a rectangle covering 40-70% of the bin's image",
      "camera mode: probability per trial that the camera is knocked off its mount before its first frame: turned 1-2 degrees about "
      "an axis drawn at random and moved 2-5 mm, while its extrinsics still say where it was",
  };
  for (int k = 0; k < static_cast<int>(FaultKind::kCount); ++k)
    a.value(faultKindName(static_cast<FaultKind>(k)), rate[k], {0.0, 1.0}, "", what[k]);
  a.value("pose_error", pose_error, {0.0, 0.2}, "m", "lateral error of a wrong perceived pose");
  a.value("pose_error_yaw", pose_error_yaw, {0.0, 3.2}, "rad", "yaw error of a wrong perceived pose");
  a.value("move_distance", move_distance, {0.0, 0.3}, "m", "how far a moved object goes");
  a.value("stall_time", stall_time, {0.0, 10.0}, "s", "how long a stalled joint holds still");
  a.value("obstacle_margin", obstacle_margin, {0.0, 0.3}, "m", "least room between an added obstacle and the robot where its motion starts and ends");
}

bool FaultOptions::any() const {
  return std::any_of(rate.begin(), rate.end(), [](double r) { return r > 0; });
}

namespace {

// FNV-1a: a stable number for a kind's name.
uint64_t nameHash(const char* name) {
  uint64_t h = 1469598103934665603ull;
  for (const char* c = name; *c; ++c) h = (h ^ static_cast<unsigned char>(*c)) * 1099511628211ull;
  return h;
}

}  // namespace

// ---- the wrapped hardware: gripper and joint faults -------------------------------------------

class FaultInjector::Faulty final : public ForwardingHardware {
 public:
  using ForwardingHardware::ForwardingHardware;
  bool block_next_close = false;   // armed: the next close command is ignored
  bool blocking = false;           // ignoring close commands until the gripper is told to open
  bool blocked = false;            // it happened
  double blocked_at = -1;
  int stall_joint = -1;
  double stall_until = 0, stall_q = 0;
  double slip_until = -1;
  double last_opening = 0.04, last_force = 40;

  void update(double now) {
    if (stall_joint >= 0 && now >= stall_until) stall_joint = -1;
    if (slip_until >= 0 && now >= slip_until) {
      slip_until = -1;
      in_.writeGripper(last_opening, last_force);  // the gripper obeys again
    }
  }

  void write(const VecX& q, const VecX& qd, const VecX& qdd) override {
    if (stall_joint < 0) return in_.write(q, qd, qdd);
    VecX q2 = q, qd2 = qd, qdd2 = qdd;
    q2[stall_joint] = stall_q;
    qd2[stall_joint] = qdd2[stall_joint] = 0;
    in_.write(q2, qd2, qdd2);
  }
  void writeGripper(double opening, double force) override {
    last_opening = opening, last_force = force;
    // The fingers stay where they are, for every close command of that grasp (an early close as
    // the approach ends, then the close stage's own) until the gripper is told to open.
    if ((block_next_close || blocking) && opening <= 1e-3) {
      if (block_next_close) blocked_at = in_.time();
      block_next_close = false;
      blocking = blocked = true;
      return in_.writeGripper(in_.gripperOpening(), force);
    }
    if (opening > 1e-3) blocking = false;
    if (slip_until >= 0) return;  // slipping: the gripper is open until the window ends
    in_.writeGripper(opening, force);
  }
};

// ---- the injector ----------------------------------------------------------------------------

FaultInjector::FaultInjector(const FaultOptions& o, SimWorld& world, uint64_t seed, uint64_t trial)
    : o_(o), world_(world) {
  for (int k = 0; k < static_cast<int>(FaultKind::kCount); ++k) {
    // Every kind draws the same numbers from its own stream whatever the rates (and whatever
    // kinds are added later: the stream is named after the kind).
    Rng r = Rng::stream(seed, trial, Purpose::kFaults, nameHash(faultKindName(static_cast<FaultKind>(k))));
    Armed& a = armed_[k];
    a.drawn = r.uniform() < o.rate[k];
    a.delay = static_cast<FaultKind>(k) == FaultKind::kGraspSlip ? r.uniform(0.2, 0.6) : r.uniform(0.1, 0.5);
    a.angle = r.uniform(-M_PI, M_PI);
    a.sign = r.uniform() < 0.5 ? -1.0 : 1.0;
    a.fraction = r.uniform();
    a.where = {r.uniform(), r.uniform()};
    if (static_cast<FaultKind>(k) == FaultKind::kExtrinsicsDrift) {
      // A knock: 1-2 degrees about an axis uniform on the sphere, 2-5 mm in a direction uniform on it.
      auto direction = [&r] {
        const double z = r.uniform(-1.0, 1.0), phi = r.uniform(-M_PI, M_PI), s = std::sqrt(1 - z * z);
        return Vec3(s * std::cos(phi), s * std::sin(phi), z);
      };
      const Vec3 axis = direction();
      const double angle = r.uniform(1.0, 2.0) * M_PI / 180;
      const Vec3 shift = r.uniform(0.002, 0.005) * direction();
      a.knock = makePose(shift, Mat3(Eigen::AngleAxisd(angle, axis)));
    }
  }
}

FaultInjector::~FaultInjector() = default;

Hardware& FaultInjector::wrap(Hardware& inner) {
  hw_ = std::make_unique<Faulty>(inner);
  hw_->block_next_close = at(FaultKind::kGripperNoClose).drawn;
  return *hw_;
}

void FaultInjector::fire(FaultKind k, TrialContext& ctx, const std::string& stage) {
  Armed& a = at(k);
  a.fired = true;
  a.onset = ctx.simTime();
  a.onset_compute = ctx.computeSoFar();
  a.stage = stage;
}

namespace {

// The objects' room to their nearest neighbour, as mostAccessibleObject measures it.
int mostRoom(const std::vector<ObjectState>& objects) {
  int best = -1;
  double room_best = -1;
  for (size_t i = 0; i < objects.size(); ++i) {
    double room = 1.0;
    for (size_t j = 0; j < objects.size(); ++j)
      if (i != j)
        room = std::min(room, (objects[i].T_world_object.translation() - objects[j].T_world_object.translation()).head<2>().norm());
    if (room > room_best) room_best = room, best = static_cast<int>(i);
  }
  return best;
}

}  // namespace

void FaultInjector::beforeCapture(TrialContext& ctx, const std::string& camera) {
  Armed& drift = at(FaultKind::kExtrinsicsDrift);
  if (!drift.drawn || drift.fired) return;
  fire(FaultKind::kExtrinsicsDrift, ctx, "perception");
  world_.setCameraOffset(camera, drift.knock);  // the camera exists: it is about to take a frame
}

void FaultInjector::onFrame(TrialContext& ctx, Frame& f) {
  // The first frame (before anything else failed) is blacked out; the first frame not blacked out,
  // before a perception has succeeded, loses depth over a region: both may strike one trial.
  const bool perceived =
      std::any_of(ctx.milestones.begin(), ctx.milestones.end(), [](const auto& m) { return m.what == "perception"; });
  if (perceived) return;
  Armed& blackout = at(FaultKind::kCameraBlackout);
  if (blackout.drawn && !blackout.fired && ctx.out.failures.empty()) {
    fire(FaultKind::kCameraBlackout, ctx, "perception");
    std::fill(f.depth.begin(), f.depth.end(), 0.0f);
    std::fill(f.rgb.begin(), f.rgb.end(), uint8_t{0});
    return;
  }
  Armed& dropout = at(FaultKind::kDepthDropout);
  if (dropout.drawn && !dropout.fired && ctx.perception.crop_half.x() > 0) {
    fire(FaultKind::kDepthDropout, ctx, "perception");
    // A rectangle of the image over the bin, its sides 63-84% of the bin's image extent (40-70%
    // of its area), its place drawn from the kind's stream: no depth there.
    const Pose& T = ctx.perception.T_world_crop;
    const Vec3 h = ctx.perception.crop_half;
    double u0 = 1e9, u1 = -1e9, v0 = 1e9, v1 = -1e9;
    for (double sx : {-1.0, 1.0})
      for (double sy : {-1.0, 1.0}) {
        const Vec3 px = f.camera.project(T * Vec3(sx * h.x(), sy * h.y(), 0));
        u0 = std::min(u0, px.x()), u1 = std::max(u1, px.x()), v0 = std::min(v0, px.y()), v1 = std::max(v1, px.y());
      }
    const double side = std::sqrt(0.4 + 0.3 * dropout.fraction);
    const double w = side * (u1 - u0), hh = side * (v1 - v0);
    const double cu = u0 + w / 2 + dropout.where[0] * (u1 - u0 - w), cv = v0 + hh / 2 + dropout.where[1] * (v1 - v0 - hh);
    const int ua = std::max(0, static_cast<int>(std::floor(cu - w / 2))), ub = std::min(f.camera.width, static_cast<int>(std::ceil(cu + w / 2)));
    const int va = std::max(0, static_cast<int>(std::floor(cv - hh / 2))), vb = std::min(f.camera.height, static_cast<int>(std::ceil(cv + hh / 2)));
    for (int v = va; v < vb; ++v)
      for (int u = ua; u < ub; ++u) f.depth[static_cast<size_t>(v) * static_cast<size_t>(f.camera.width) + static_cast<size_t>(u)] = 0.0f;
  }
}

void FaultInjector::onPerception(TrialContext& ctx, PerceptionResult& r) {
  const bool first = !std::any_of(ctx.milestones.begin(), ctx.milestones.end(), [](const auto& m) { return m.what == "perception"; }) &&
                     ctx.out.failures.empty();
  if (!first) return;
  if (at(FaultKind::kPerceptionDropout).drawn && !at(FaultKind::kPerceptionDropout).fired) {
    fire(FaultKind::kPerceptionDropout, ctx, "perception");
    r.ok = false;
    r.objects.clear();
    r.reason = "no object detected (sensor dropout)";
    return;
  }
  if (!r.ok || r.objects.empty()) return;
  Armed& pose = at(FaultKind::kPerceptionPoseError);
  if (pose.drawn && !pose.fired) {
    fire(FaultKind::kPerceptionPoseError, ctx, "perception");
    ObjectState& o = r.objects[mostRoom(r.objects)];
    pose.object = ctx.truthIndex(o.index);
    o.T_world_object.translation() += o_.pose_error * Vec3(std::cos(pose.angle), std::sin(pose.angle), 0);
    o.T_world_object.linear() = rotZ(pose.sign * o_.pose_error_yaw) * o.T_world_object.linear();
  }
  Armed& phantom = at(FaultKind::kFalseDetection);
  if (phantom.drawn && !phantom.fired && ctx.perception.crop_half.x() > 0) {
    // A phantom where the bin has room, placed first in the list, at the roomiest spot where it is
    // the object the robot will go for first (the most accessible, as mostAccessibleObject
    // measures it: room to the nearest neighbour; ties go to the first).
    const Pose& T = ctx.perception.T_world_crop;
    const Vec3 h = ctx.perception.crop_half;
    // Where a real cube could lie and be grasped: as far from the walls as the spawner keeps
    // cubes (objects.wall_margin's default), so that the phantom is found out by closing on it.
    const double margin = 0.07;
    std::vector<std::pair<double, Vec3>> spots;
    auto consider = [&](const Vec3& p) {
      const Vec3 local = T.inverse() * p;
      if (std::abs(local.x()) > h.x() - margin + 1e-9 || std::abs(local.y()) > h.y() - margin + 1e-9) return;
      double room = 1.0;
      for (const ObjectState& o : r.objects) room = std::min(room, (o.T_world_object.translation() - p).head<2>().norm());
      spots.push_back({room, p});
    };
    // A grid over the bin, and rings around each object (a spot exactly as far from an object as
    // that object is from it ties with it, and ties go to the phantom).
    const int n = 32;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; j <= n; ++j)
        consider(T * Vec3((-1 + 2.0 * i / n) * (h.x() - margin), (-1 + 2.0 * j / n) * (h.y() - margin), 0));
    for (const ObjectState& o : r.objects)
      for (double radius = 0.07; radius < 0.3; radius += 0.005)
        for (int k = 0; k < 48; ++k) {
          const Vec3 c = o.T_world_object.translation();
          consider(Vec3(c.x() + radius * std::cos(k * M_PI / 24), c.y() + radius * std::sin(k * M_PI / 24), T.translation().z()));
        }
    std::stable_sort(spots.begin(), spots.end(), [](const auto& x, const auto& y) { return x.first > y.first; });
    ObjectState ghost = r.objects.front();
    ghost.index = 1000;
    ghost.name = "phantom";
    for (const auto& [room, p] : spots) {
      if (room < 2 * ghost.half_size.head<2>().norm()) break;  // it would overlap a real object
      std::vector<ObjectState> seen = r.objects;
      ghost.T_world_object = makePose(p + Vec3(0, 0, ghost.half_size.z()), rotZ(phantom.angle));
      seen.insert(seen.begin(), ghost);
      if (mostRoom(seen) == 0) {
        r.objects = std::move(seen);
        fire(FaultKind::kFalseDetection, ctx, "perception");
        break;
      }
    }
  }
}

bool FaultInjector::failPlanning(TrialContext& ctx, const std::string& stage) {
  Armed& a = at(FaultKind::kPlanningFailure);
  if (!a.drawn || a.fired) return false;
  fire(FaultKind::kPlanningFailure, ctx, stage);
  a.milestone = "plan:" + stage;
  return true;
}

namespace {

Vec3 aabbHalf(const Obstacle& o) {
  Vec3 h = o.size;
  if (o.type == Obstacle::Type::kSphere) h = Vec3::Constant(o.size.x());
  if (o.type == Obstacle::Type::kCylinder || o.type == Obstacle::Type::kCapsule)
    h = Vec3(o.size.x(), o.size.x(), o.size.y() + (o.type == Obstacle::Type::kCapsule ? o.size.x() : 0.0));
  return o.T_world.linear().cwiseAbs() * h;
}

bool aabbOverlap(const Obstacle& a, const Obstacle& b) {
  const Vec3 d = (a.T_world.translation() - b.T_world.translation()).cwiseAbs();
  return (d.array() < (aabbHalf(a) + aabbHalf(b)).array()).all();
}

}  // namespace

void FaultInjector::onPlanned(TrialContext& ctx, const Plan& plan) {
  Armed& a = at(FaultKind::kObstacleAdded);
  if (!a.drawn || a.fired || world_.numObstacles() == 0) return;
  // The place's transit, which crosses the open table low between the bin and the place area.
  if (plan.name != "place") return;
  const PlanStep* step = nullptr;
  for (const PlanStep& s : plan.steps)
    if (s.kind == PlanStep::Kind::kTrajectory && s.stage == "move_preplace") step = &s;
  if (!step || step->trajectory.size() < 10) return;
  const JointTrajectory& tr = step->trajectory;
  PlanningScene scene;
  scene.finger_opening = step->opening;
  if (ctx.held >= 0) {
    attachObject(scene, ctx.held_record.half_size, ctx.T_tcp_held, ctx.held_pieces);
  }
  const std::vector<Obstacle> cell = world_.staticObstacles();
  const TruthScope world(ctx.hw, "a fault injected");
  const std::vector<ObjectState> objects = ctx.hw.objects();
  Obstacle column;
  column.type = Obstacle::Type::kBox;
  column.size = world_.obstacleHalfSize(0);
  column.name = "obstacle_0";
  // A column standing on the cell under the path, tall enough to stop the hand, clear of the cell,
  // the objects and the robot where the motion starts and ends (and at home): the way around it
  // exists, the way planned does not.
  for (double f : {0.5, 0.4, 0.6, 0.3, 0.7}) {
    const VecX q = tr.q.col(static_cast<int>(f * (tr.size() - 1)));
    const Vec3 p = ctx.robot.fk(q).translation();
    const Obstacle* support = nullptr;
    double top = -1e9;
    for (const Obstacle& o : cell) {
      if (o.type != Obstacle::Type::kBox) continue;
      const Vec3 local = o.T_world.inverse() * p;
      const double t = o.T_world.translation().z() + aabbHalf(o).z();
      if (std::abs(local.x()) <= o.size.x() && std::abs(local.y()) <= o.size.y() && t < p.z() && t > top) top = t, support = &o;
    }
    if (!support || top + 2 * column.size.z() < p.z() + 0.02) continue;
    column.T_world = makePose(Vec3(p.x(), p.y(), top + column.size.z() + 0.001), rotZ(a.angle));
    bool clear = true;
    for (const Obstacle& o : cell) clear = clear && (&o == support || !aabbOverlap(column, o));
    for (const ObjectState& o : objects) {
      Obstacle box;
      box.size = o.half_size;
      box.T_world = o.T_world_object;
      clear = clear && !aabbOverlap(column, box);
    }
    if (!clear) continue;
    scene.obstacles = {column};
    auto roomy = makeChecker("fcl", ctx.robot, scene, o_.obstacle_margin);
    if (!roomy->isValid(tr.q.col(0)) || !roomy->isValid(tr.q.col(tr.size() - 1)) || !roomy->isValid(plan.q_end) ||
        !roomy->isValid(ctx.robot.home()))
      continue;
    if (makeChecker("fcl", ctx.robot, scene, 0.0)->isValid(q)) continue;  // it must be in the way
    world_.placeObstacle(0, column.T_world);
    fire(FaultKind::kObstacleAdded, ctx, "connect_place");
    a.milestone = "place";
    return;
  }
}

void FaultInjector::beforeStep(TrialContext& ctx) {
  const double now = ctx.simTime();
  if (hw_) {
    hw_->update(hw_->time());
    Armed& close = at(FaultKind::kGripperNoClose);
    if (hw_->blocked && !close.fired) {
      fire(FaultKind::kGripperNoClose, ctx, "close_gripper");
      close.object = ctx.truthIndex(ctx.picking);
    }
  }
  if (ctx.out.stages.size() != stage_index_) {
    stage_index_ = ctx.out.stages.size();
    stage_ = ctx.out.stages.back().name;
    stage_start_ = now;
  }
  const double in_stage = now - stage_start_;
  // The target leaves, or is pushed aside, while the arm moves to it.
  for (FaultKind k : {FaultKind::kObjectRemoved, FaultKind::kObjectMoved}) {
    Armed& a = at(k);
    const int truth = ctx.truthIndex(ctx.picking);
    if (!a.drawn || a.fired || truth < 0) continue;
    if (!((stage_ == "move_pregrasp" && in_stage >= a.delay) || stage_ == "approach")) continue;
    fire(k, ctx, stage_);
    a.object = truth;
    if (k == FaultKind::kObjectRemoved) {
      world_.parkObject(truth);
      continue;
    }
    // Pushed aside within the bin: the first direction that keeps it 7 cm inside the walls (as
    // spawned) and out of the other objects.
    const Pose T0 = world_.object(truth).T_world_object;
    const Pose& crop = ctx.perception.T_world_crop;
    const Vec3 h = ctx.perception.crop_half;
    for (int turn = 0; turn < 8; ++turn) {
      const double angle = a.angle + turn * M_PI / 4;
      Pose T = T0;
      T.translation() += o_.move_distance * Vec3(std::cos(angle), std::sin(angle), 0);
      const Vec3 local = crop.inverse() * T.translation();
      if (h.x() > 0 && (std::abs(local.x()) > h.x() - 0.07 || std::abs(local.y()) > h.y() - 0.07)) continue;
      world_.setObjectPose(truth, T);
      if (world_.objectPenetration(truth) < 0.001) break;
      world_.setObjectPose(truth, T0);
    }
  }
  // The held object slips out of the fingers as it is lifted out of the bin: it falls back in.
  Armed& slip = at(FaultKind::kGraspSlip);
  if (slip.drawn && !slip.fired && hw_ && ctx.held_truth >= 0 && stage_ == "lift" && in_stage >= slip.delay) {
    fire(FaultKind::kGraspSlip, ctx, stage_);
    slip.object = ctx.held_truth;
    if (ctx.options.weld) hw_->inner().attach(ctx.held_truth, false);
    hw_->inner().writeGripper(ctx.robot.spec().gripper.travel, ctx.options.grasp_force);
    hw_->slip_until = hw_->time() + 0.3;
  }
  // The fastest-moving joint stalls for a while during a move (to the pre-grasp or the pre-place).
  Armed& stall = at(FaultKind::kJointStall);
  const std::string stall_stage = stall.sign > 0 ? "move_pregrasp" : "move_preplace";
  if (stall.drawn && !stall.fired && hw_ && stage_ == stall_stage && in_stage >= stall.delay) {
    fire(FaultKind::kJointStall, ctx, stage_);
    Eigen::Index j = 0;
    hw_->jointVelocities().cwiseAbs().maxCoeff(&j);
    hw_->stall_joint = static_cast<int>(j);
    hw_->stall_q = hw_->jointPositions()[j];
    hw_->stall_until = hw_->time() + o_.stall_time;
    stall.milestone = stall_stage == "move_pregrasp" ? "pick" : "place";
  }
}

std::vector<FaultRecord> FaultInjector::report(const TrialContext& ctx) const {
  constexpr int kKinds = static_cast<int>(FaultKind::kCount);
  // Recovering from a fault means the stage it interrupted succeeding later: perceiving, planning
  // that stage, picking, or placing. A fault is detected by the first failure after its onset that
  // comes before that success; a fault followed by the success and no failure had no effect.
  std::array<const TrialContext::Milestone*, kKinds> done{};
  std::array<const RecordedFailure*, kKinds> detection{};
  for (int k = 0; k < kKinds; ++k) {
    const Armed& a = armed_[k];
    if (!a.fired) continue;
    std::string needed = a.milestone;
    if (needed.empty()) {
      switch (static_cast<FaultKind>(k)) {
        case FaultKind::kPerceptionDropout:
        case FaultKind::kCameraBlackout:
        case FaultKind::kDepthDropout:
        case FaultKind::kExtrinsicsDrift: needed = "perception"; break;
        case FaultKind::kGraspSlip: needed = "place"; break;
        default: needed = "pick"; break;
      }
    }
    for (const auto& m : ctx.milestones)
      if (m.what == needed && m.sim_time >= a.onset - 1e-9 && m.compute >= a.onset_compute) {
        done[k] = &m;
        break;
      }
    for (const RecordedFailure& r : ctx.out.failures)
      if (r.failure.kind != FailureKind::kHalted && r.sim_time >= a.onset - 1e-9 &&
          (!done[k] || r.sim_time <= done[k]->sim_time + 1e-9)) {
        detection[k] = &r;
        break;
      }
  }
  const int removed_k = static_cast<int>(FaultKind::kObjectRemoved);
  const Armed& removed = armed_[removed_k];
  std::vector<FaultRecord> out;
  for (int k = 0; k < kKinds; ++k) {
    const Armed& a = armed_[k];
    if (!a.fired) continue;
    const FaultKind kind = static_cast<FaultKind>(k);
    FaultRecord f;
    f.kind = faultKindName(kind);
    f.stage = a.stage;
    f.sim_time = a.onset;
    f.detected = detection[k] != nullptr;
    if (!f.detected) {
      f.outcome = "no_effect";
      out.push_back(f);
      continue;
    }
    f.detected_time = detection[k]->sim_time;
    f.detected_by = detection[k]->failure.stage + " (" + failureKindName(detection[k]->failure.kind) + ")";
    for (const auto& m : ctx.milestones) {
      if (m.sim_time < f.detected_time - 1e-9) continue;
      if (!f.recovery.empty()) f.recovery += ", ";
      f.recovery += m.what;
      if (&m == done[k]) break;
    }
    // The trial failing after the recovery belongs to this fault unless a later one struck after it.
    bool later_fault = false;
    if (done[k])
      for (int j = 0; j < kKinds; ++j)
        later_fault = later_fault || (j != k && detection[j] && armed_[j].onset >= done[k]->sim_time - 1e-9);
    // Object taken away: the one this fault concerned, or the last one, before it was recovered.
    const bool taken = removed.fired && k != removed_k &&
                       ((a.object >= 0 && a.object == removed.object) || (!done[k] && ctx.out.objects_left_in_bin == 0));
    if (kind == FaultKind::kObjectRemoved) {
      // No action can pick an object that is gone: the correct end is to notice (a failure) and
      // move on without harm.
      f.outcome = ctx.out.collision_count == 0 && !ctx.out.sim_unstable ? "given_up" : "unrecovered";
    } else if (taken) {
      f.outcome = "superseded";
    } else if (done[k] && (ctx.out.success || later_fault)) {
      f.outcome = "recovered";
      f.mttr = (done[k]->sim_time - a.onset) + (done[k]->compute - a.onset_compute);
    } else {
      f.outcome = "unrecovered";
    }
    out.push_back(f);
  }
  return out;
}

}  // namespace mm
