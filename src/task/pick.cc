// The pick: grasp candidates, the grasp selected by IK, collision, approach and lift checks, and
// the pick planned from where the arm rests (open, connect, approach, close, attach, lift).
#include "task/pick_place.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/error.h"
#include "grasp/cloud_grasps.h"
#include "planning/blend.h"
#include "planning/chomp.h"
#include "planning/time_parameterization.h"
#include "sim/hardware.h"
#include "task/external_component.h"
#include "task/plan_steps.h"

namespace mm {

// ---- pick ------------------------------------------------------------------------------------

std::vector<GraspCandidate> graspCandidates(TrialContext& ctx, const ObjectState& object) {
  std::vector<Obstacle> neighbours = ctx.statics;
  for (const ObjectState& b : ctx.objects)
    if (b.index != object.index && !picked(ctx, b.index))
      for (const Obstacle& piece : obstaclesOf(b)) neighbours.push_back(piece);
  const double preferred_yaw = yawOf(ctx.robot.fk(ctx.robot.home()).linear());
  const GraspOptions go = graspOptionsFor(ctx.robot.spec().gripper, ctx.options);
  return mm::graspCandidates(object, preferred_yaw, Vec3::Zero(), neighbours, go);
}

namespace {

using PerObject = std::vector<std::pair<ObjectState, std::vector<GraspCandidate>>>;

// [m] an object this near where a pick failed is tried after the others (underObjects).
constexpr double kRetryDistance = 0.03;

// The distance from `p` to the object as the planner sees it (its boxes, a cylinder as the box
// around it); 0 inside.
double distanceToBoxes(const ObjectState& o, const Vec3& p) {
  double best = INFINITY;
  for (const Obstacle& b : obstaclesOf(o)) {
    const Vec3 half = b.type == Obstacle::Type::kBox ? b.size : Vec3(b.size.x(), b.size.x(), b.size.y());
    const Vec3 local = b.T_world.inverse() * p;
    best = std::min(best, (local.cwiseAbs() - half).cwiseMax(0.0).norm());
  }
  return best;
}

// A stage of grasp candidates from a view, ended with its failure (or none): its compute time, less
// `apart` (an external component's own wall time, recorded apart), booked under the pick's planning.
struct CandidatesStage {
  CandidatesStage(TrialContext& c, const char* name) : ctx(c), st(&c.stage(name)), t(Clock::now()) {}
  Failure operator()(const Failure& f) const {
    st->compute_seconds = std::max(0.0, since(t) - apart);
    ctx.out.plan_pick_time += st->compute_seconds;
    st->ok = f.ok();
    return f;
  }
  TrialContext& ctx;
  StageRecord* st;
  Clock::time_point t;
  double apart = 0;
};

// Each candidate of a grasp from points under the perceived object (not yet picked) its pads close
// on, with its torque arm to that object's centre (the middle of what the camera saw of it: its
// columns), in the order of each object's first (those near where the last pick failed after the
// others); `none` and `several` count those closing on no object and on two or more. Returns how
// many were kept.
int underObjects(const TrialContext& ctx, const std::vector<GraspCandidate>& candidates, const CloudGraspOptions& co, PerObject& out,
                 int& none, int& several) {
  std::vector<ObjectState> known;
  for (const ObjectState& o : ctx.objects)
    if (!picked(ctx, o.index)) known.push_back(o);
  none = several = 0;
  int kept = 0;
  std::vector<int> slot(known.size(), -1);
  for (GraspCandidate g : candidates) {
    const int k = objectBetweenPads(g, known, co);
    if (k < 0) {
      ++(k == -1 ? none : several);
      continue;
    }
    const Vec3 y = g.T_world_tcp.linear().col(1), d = known[k].T_world_object.translation() - g.T_world_tcp.translation();
    g.torque_arm = (d - d.dot(y) * y).norm();  // recorded; the ranking stays the detector's
    ++kept;
    if (slot[k] < 0) slot[k] = static_cast<int>(out.size()), out.push_back({known[k], {}});
    out[slot[k]].second.push_back(std::move(g));
  }
  // After a pick that failed (the hand stopped on contact, the fingers closed on nothing or did
  // not close), the objects within kRetryDistance of where it was to close go last: whatever
  // stopped it is likely still there (a pushed object moves a little), and the round ends after
  // two failures in a row.
  if (ctx.failed_pick_at) {
    const Vec3 at = *ctx.failed_pick_at;
    std::stable_partition(out.begin(), out.end(), [&](const auto& entry) { return distanceToBoxes(entry.first, at) > kRetryDistance; });
  }
  return kept;
}

}  // namespace

Failure cloudGraspCandidates(TrialContext& ctx, std::vector<std::pair<ObjectState, std::vector<GraspCandidate>>>& out) {
  out.clear();
  const CandidatesStage done(ctx, "cloud_grasps");
  Frame frame;
  std::string why;
  if (!captureView(ctx, frame, &why)) return done({"cloud_grasps", FailureKind::kPerception, why});
  CloudGraspOptions co = cloudGraspOptionsFor(ctx.robot.spec().gripper, ctx.options, ctx.perception);
  // The perceived objects and the patches no segment explains, as the planner will see them (a
  // cylinder as the box around it).
  auto box = [](const Obstacle& b, int owner) {
    const bool cylinder = b.type == Obstacle::Type::kCylinder;
    return OwnedBox{b.T_world, cylinder ? Vec3(b.size.x(), b.size.x(), b.size.y()) : b.size, owner};
  };
  for (const ObjectState& o : ctx.objects)
    if (!picked(ctx, o.index)) {
      const int owner = static_cast<int>(co.objects.size());
      co.objects.push_back(o);
      for (const Obstacle& b : obstaclesOf(o)) co.boxes.push_back(box(b, owner));
    }
  for (const Obstacle& b : ctx.seen_obstacles) co.boxes.push_back(box(b, -1));
  // The cell's box-shaped walls as the grasp's checks will take them (planning.wall_padding): a
  // hand whose fingers go down within that of a wall is dropped (counted as into a neighbour), as
  // the approach's check would refuse it. Not the floors (the parts whose top is within 5 mm of the
  // region's floor): the fingertips come near them.
  if (ctx.options.wall_padding > co.padding) {
    const double floor = co.T_world_region.translation().z() + 0.005;
    for (const Obstacle& s : wallPaddedStatics(ctx, co.padding))
      if (s.type == Obstacle::Type::kBox && s.T_world.translation().z() + s.T_world.linear().row(2).cwiseAbs().dot(s.size) > floor)
        co.boxes.push_back(box(s, -1));
  }
  const Vec3 preferred_x = ctx.robot.fk(ctx.robot.home()).linear().col(0);
  const CloudGraspResult r = cloudGrasps(frame, co, preferred_x, ctx.rng_grasp);
  int none = 0, several = 0;
  underObjects(ctx, r.candidates, co, out, none, several);
  if (out.empty()) {
    char buf[400];
    if (r.candidates.empty())
      std::snprintf(buf, sizeof buf,
                    "no grasp from the camera's points (%d hands from %d seeds: %d too wide, %d too low, %d on the floor or a wall, %d fingers' "
                    "and %d hand's approach blocked, %d sparse, %d not antipodal, %d into a neighbour, %d into unseen space, %d tilted)",
                    r.hands, r.seeds, r.too_wide, r.too_low, r.on_cell, r.fingers_blocked, r.hand_blocked, r.sparse, r.not_antipodal,
                    r.neighbour, r.unseen, r.tilted);
    else
      std::snprintf(buf, sizeof buf, "no grasp from the camera's points closes on one perceived object (%zu candidates: %d on none, %d on two or more)",
                    r.candidates.size(), none, several);
    return done({"cloud_grasps", FailureKind::kNoGrasp, buf});
  }
  return done({});
}

Failure externalGraspCandidates(TrialContext& ctx, std::vector<std::pair<ObjectState, std::vector<GraspCandidate>>>& out) {
  out.clear();
  CandidatesStage done(ctx, "external_grasps");
  if (!ctx.external)  // the experiment's checks refuse a tree that asks with no component configured
    return done({"external_grasps", FailureKind::kPrecondition, "no external component (external.command) in this run"});
  Frame frame;
  std::string why;
  if (!captureView(ctx, frame, &why)) return done({"external_grasps", FailureKind::kPerception, why});
  const GraspOptions go = graspOptionsFor(ctx.robot.spec().gripper, ctx.options);
  ExternalRequest request;
  request.want = ExternalWant::kGrasps;
  request.trial = ctx.trial_index;
  request.seed = ctx.run_seed;
  request.camera = frame.camera;
  request.T_world_region = ctx.perception.T_world_crop;
  request.region_half = Vec3(ctx.perception.crop_half.x(), ctx.perception.crop_half.y(), ctx.perception.crop_height);
  request.gripper = {go.max_opening, go.finger_thickness,    go.pad_half_width,      go.pad_z_min, go.pad_z_max,
                     go.hand_back,   go.hand_half_thickness, go.hand_half_width, ctx.options.finger_margin};
  const ExternalCall call = ctx.external->call(request, frame);
  done.apart = call.answer_seconds;  // the component's time, not the harness's
  ExternalCallRecord rec;
  rec.time = ctx.simTime();
  rec.result = call.result;
  rec.reason = call.reason;
  rec.write_seconds = call.write_seconds;
  rec.answer_seconds = call.answer_seconds;
  rec.grasps = static_cast<int>(call.answer.grasps.size());
  rec.answer = call.line;
  // Each candidate under the perceived object its pads close on; the opening the component gives
  // (the pads' distance as the hand comes down) less the finger margin each side (the request's
  // gripper says it) is the width they close on.
  std::vector<GraspCandidate> candidates;
  for (const ExternalGrasp& e : call.answer.grasps) {
    GraspCandidate g;
    g.T_world_tcp = e.T_world_tcp;
    g.type = GraspType::kExternal;
    g.width = std::max(0.002, e.opening - 2 * ctx.options.finger_margin);
    g.score = e.score;
    g.approach = -e.T_world_tcp.linear().col(2);
    g.yaw = yawOf(e.T_world_tcp.linear());
    candidates.push_back(g);
  }
  int none = 0, several = 0;
  const CloudGraspOptions co = cloudGraspOptionsFor(ctx.robot.spec().gripper, ctx.options, ctx.perception);
  rec.grasps_on_objects = underObjects(ctx, candidates, co, out, none, several);
  ctx.out.external_calls.push_back(rec);
  if (!call.ok()) return done({"external_grasps", FailureKind::kPerception, call.reason});
  // The component's order is its ranking: each object's candidates best first by its scores.
  for (auto& [object, mine] : out)
    std::stable_sort(mine.begin(), mine.end(), [](const GraspCandidate& a, const GraspCandidate& b) { return a.score > b.score; });
  if (out.empty()) {
    char buf[300];
    std::snprintf(buf, sizeof buf, "no grasp from the external component closes on one perceived object (%zu candidates: %d on none, %d on two or more)",
                  call.answer.grasps.size(), none, several);
    return done({"external_grasps", FailureKind::kNoGrasp, buf});
  }
  return done({});
}

CloudGraspOptions cloudGraspOptionsFor(const GripperSpec& gripper, const TaskOptions& task, const PerceptionOptions& perception) {
  CloudGraspOptions co = cloudGraspOptionsFor(graspOptionsFor(gripper, task));
  co.T_world_region = perception.T_world_crop;
  co.region_half = perception.crop_half;
  co.region_height = perception.crop_height;
  co.depth_sigma_k = perception.noise.k;  // the sensor's datasheet: the noise the experiment gives it
  co.finger_margin = task.finger_margin;
  co.padding = task.cloudGraspPadding();
  co.seeds = task.cloud_seeds;
  co.min_bite = task.cloud_bite;
  co.floor_contacts = task.cloud_floor_contacts;
  co.snap_down = task.cloud_snap_down;
  co.weak_score = task.cloud_weak_score;
  co.cone = std::min(task.cloud_cone, std::atan(gripper.pad_friction));  // no wider than the pads' own cone
  return co;
}

GraspOptions graspOptionsFor(const GripperSpec& gripper, const TaskOptions& task) {
  GraspOptions go = task.grasp;
  go.max_opening = 2 * gripper.travel;
  go.friction = gripper.pad_friction;
  go.approach_distance = task.approach_distance;
  // The pads: the +y finger's first box, in the TCP frame (z along the approach).
  for (const ShapeSpec& sh : gripper.fingers[0].shapes)
    if (sh.type == ShapeSpec::Type::kBox) {
      go.pad_half_width = sh.half[0];
      go.finger_thickness = 2 * sh.half[1];
      go.pad_z_min = gripper.finger_z + sh.pos[2] - sh.half[2] - gripper.tcp_offset;
      go.pad_z_max = gripper.finger_z + sh.pos[2] + sh.half[2] - gripper.tcp_offset;
      break;
    }
  // The hand body: its front (nearest the TCP) and its half extents across.
  double front = -INFINITY, thick = 0, wide = 0;
  for (const ShapeSpec& sh : gripper.hand.shapes) {
    if (sh.type == ShapeSpec::Type::kMesh) {  // its hull's vertices, placed
      const Pose T = makePose(Vec3(sh.pos[0], sh.pos[1], sh.pos[2]), Quat(sh.quat[0], sh.quat[1], sh.quat[2], sh.quat[3]));
      for (const Vec3& v : meshHull(sh.mesh, Vec3(sh.scale[0], sh.scale[1], sh.scale[2]))->vertices) {
        const Vec3 p = T * v;
        front = std::max(front, p.z()), thick = std::max(thick, std::abs(p.x())), wide = std::max(wide, std::abs(p.y()));
      }
    } else if (sh.type == ShapeSpec::Type::kBox) {
      front = std::max(front, sh.pos[2] + sh.half[2]);
      thick = std::max(thick, std::abs(sh.pos[0]) + sh.half[0]);
      wide = std::max(wide, std::abs(sh.pos[1]) + sh.half[1]);
    } else {
      const double r = sh.radius;
      const double z = sh.type == ShapeSpec::Type::kSphere ? sh.pos[2] + r : std::max(sh.from[2], sh.to[2]) + (sh.type == ShapeSpec::Type::kCapsule ? r : 0.0);
      front = std::max(front, z);
      thick = std::max(thick, r);
      wide = std::max(wide, r);
    }
  }
  if (std::isfinite(front)) go.hand_back = gripper.tcp_offset - front;
  if (thick > 0) go.hand_half_thickness = thick, go.hand_half_width = wide;
  return go;
}

namespace {

// The checks a grasp candidate must pass (pre-grasp IK and no collision there, a straight
// collision-free approach and lift), with the checkers of selectGrasp; fills `out`'s motions.
struct GraspCheckers {
  std::unique_ptr<CollisionChecker> full, no_target;
  double padding = 0;            ///< [m] theirs, and the lift's
  double finger_opening = 0.04;  ///< [m] the fingers' opening (each) in their scenes
};

// The robot's padding in a grasp's checks: the tight pass's (margin below finger_margin) is that
// margin; a grasp from the camera's points was cleared against them with cloud_padding; else the
// planner's.
double graspPadding(const TaskOptions& o, double margin, bool cloud) {
  if (cloud) return o.cloudGraspPadding();
  return margin < o.finger_margin ? std::min(o.padding, margin) : o.padding;
}

// `margin`: the fingers open this much wider than the object (or than `half_width`, the widest
// half width of the candidates' when they give it: grasps from the camera's points).
GraspCheckers graspCheckers(const TrialContext& ctx, const ObjectState& object, double margin, double half_width = -1) {
  const TaskOptions& o = ctx.options;
  PlanningScene full_scene = planningScene(ctx, -1, false), approach_scene = planningScene(ctx, object.index, false);
  const double widest = half_width >= 0 ? 2 * half_width : 2 * std::max(object.half_size.x(), object.half_size.y());
  full_scene.finger_opening = approach_scene.finger_opening = std::min(ctx.robot.spec().gripper.travel, widest / 2 + margin);
  const double padding = graspPadding(o, margin, half_width >= 0);
  return {wallPaddedChecker(ctx, full_scene, padding), wallPaddedChecker(ctx, approach_scene, padding), padding,
          full_scene.finger_opening};
}

// The finger margins to try in turn: the configured one, then the tight one in clutter.
std::vector<double> graspMargins(const TaskOptions& o) {
  std::vector<double> m{o.finger_margin};
  if (o.tight_margin > 0 && o.tight_margin < o.finger_margin) m.push_back(o.tight_margin);
  return m;
}

Failure tryGrasp(TrialContext& ctx, const ObjectState& object, const GraspCandidate& g, GraspCheckers& checkers,
                 double approach_distance, Rng& rng, GraspSolution& out, long& collision_checks) {
  const TaskOptions& o = ctx.options;
  const Pose& T_grasp = g.T_world_tcp;
  Pose T_pre = T_grasp;
  T_pre.translation() += approach_distance * g.approach;
  // The pre-grasp nearest home of those free of collision from whose arm the approach's line stays
  // clear of the arm itself (a redundant arm's other elbow or wrist turn: the nearest one may fold
  // link on link as the hand goes down, whatever is around); the line is checked in full below.
  // When there is none, the nearest one, and the checks below say why it fails.
  PlanningScene alone;
  alone.finger_opening = checkers.finger_opening;
  auto self = makeChecker(o.checker, ctx.robot, alone, 0.0);
  Rng probe_rng = rng;  // the probe's descents leave the trial's stream as it was
  const IkFunction probe = ikNear(ctx, probe_rng);
  auto clear = [&](const VecX& q) {
    if (!checkers.full->isValid(q)) return false;
    VecX at = q, next;
    for (int k = 1; k <= 3; ++k) {
      Pose T = T_pre;
      T.translation() = T_pre.translation() + (T_grasp.translation() - T_pre.translation()) * (k / 3.0);
      if (!probe(T, at, next) || !self->isValid(next)) return false;
      at = next;
    }
    return true;
  };
  IkResult pre = ikFar(ctx, T_pre, ctx.robot.home(), rng, clear);
  collision_checks += self->checks();
  const bool cleared = pre.ok();
  if (!cleared) pre = ikFar(ctx, T_pre, ctx.robot.home(), rng);
  if (!pre.ok()) return {"grasp_pose_ik", FailureKind::kIk, "pre-grasp: " + pre.reason};
  if (!cleared && !checkers.full->isValid(pre.q()))
    return {"grasp_pose_ik", FailureKind::kCollision, "pre-grasp configuration in collision (" + checkers.full->lastCollision() + ")"};
  const IkFunction near = ikNear(ctx, rng);
  out.approach = planCartesianLine(ctx.robot, *checkers.no_target, pre.q(), T_grasp, near, o.cartesian);
  if (!out.approach.ok) return {"approach", out.approach.kind, out.approach.reason};
  out.q_pre = pre.q();
  out.q_grasp = out.approach.waypoints.back();
  out.T_tcp_object = T_grasp.inverse() * object.T_world_object;
  // Lift with the object attached; it leaves the bin floor it rests on.
  PlanningScene ls = planningScene(ctx, object.index, false);
  attachObject(ls, object.half_size, out.T_tcp_object, object.pieces);
  // The fingers closed on it: a grasp from the camera's points says how wide it closes on.
  ls.finger_opening = fromPoints(g.type) ? g.width / 2 : object.half_size.y();
  // It rests on the floor and, in a pile, against its neighbours; a mesh object's pieces are
  // checked as their boxes, which reach past the pieces: the lift lets them overlap this much,
  // and lifted straight up it leaves the cell's parts it rests on (those whose top is not above
  // its lowest point).
  ls.attached_padding = object.pieces ? -kPiecesLiftTolerance : -kSupportTolerance;
  if (object.pieces) {
    double bottom = INFINITY;
    for (const ConvexPiece& piece : *object.pieces)
      for (const Vec3& v : piece.vertices) bottom = std::min(bottom, (object.T_world_object * v).z());
    for (const Obstacle& s : ctx.statics) {
      const double top = s.T_world.translation().z() + s.T_world.linear().row(2).cwiseAbs().dot(s.size);
      if (s.type == Obstacle::Type::kBox && top <= bottom + kSupportTolerance) ls.attached_ignore.push_back(s.name);
    }
  }
  const double lift_padding = fromPoints(g.type) ? checkers.padding : o.padding;
  auto lifting = makeChecker(o.checker, ctx.robot, ls, lift_padding);
  // A segment with no model is the columns under what the camera saw of it, and so is each of its
  // neighbours and each patch no segment explains: where they overlap as it is grasped, the same
  // space is claimed by both (the room under an overhang, one object cut in two), and which one
  // holds it is unknown. Lifted straight up, the held object leaves such a neighbour as it leaves
  // its support (MoveIt Task Constructor's pick allows the object's collisions with its support
  // surfaces for the lift the same way); the hand and the arm are still checked against it.
  // A mesh object's boxes likewise reach past its pieces into the cell's parts it rests on or
  // against (a wedge's slope toward a bin wall, a tilted piece's box below the floor): a part of
  // the cell they overlap where it is grasped is left the same way.
  const bool segmented = segmentedObjects(ctx.perception);
  if (segmented || object.pieces) {
    for (int k = 0; k < 8 && !lifting->isValid(out.q_grasp); ++k) {
      const std::string hit = lifting->lastCollision(), held = "held object / ";
      const std::string name = hit.compare(0, held.size(), held) == 0 ? hit.substr(held.size()) : "";
      const bool neighbour =
          segmented && (std::any_of(ctx.objects.begin(), ctx.objects.end(), [&](const ObjectState& b) { return b.name == name; }) ||
                        std::any_of(ctx.seen_obstacles.begin(), ctx.seen_obstacles.end(), [&](const Obstacle& b) { return b.name == name; }));
      const bool cell = object.pieces && std::any_of(ctx.statics.begin(), ctx.statics.end(), [&](const Obstacle& b) { return b.name == name; });
      if (name.empty() || (!neighbour && !cell)) break;  // the hand or the arm: a real collision
      ls.attached_ignore.push_back(name);
      lifting = makeChecker(o.checker, ctx.robot, ls, lift_padding);
    }
  }
  Pose T_lift = T_grasp;
  T_lift.translation().z() += o.lift_height;
  out.lift = planCartesianLine(ctx.robot, *lifting, out.q_grasp, T_lift, near, o.cartesian);
  collision_checks += lifting->checks();
  if (!out.lift.ok) return {"lift", out.lift.kind, out.lift.reason};
  return {};
}

// Whether `g` closed on nothing before in this trial (the grasp executed; a cloud grasp either way
// round about its approach, the same grasp).
bool failedBefore(const TrialContext& ctx, const GraspCandidate& g) {
  const Mat3 turned = halfTurnAboutApproach(g.T_world_tcp.linear());
  return std::any_of(ctx.failed_grasps.begin(), ctx.failed_grasps.end(), [&](const Pose& T) {
    if ((T.translation() - g.T_world_tcp.translation()).norm() >= 1e-3) return false;
    return angleBetween(T.linear(), g.T_world_tcp.linear()) < 1e-2 ||
           (fromPoints(g.type) && angleBetween(T.linear(), turned) < 1e-2);
  });
}

}  // namespace

bool graspable(TrialContext& ctx, const ObjectState& object) {
  // A probe: its own copy of the IK stream and no record, so that choosing leaves the trial's
  // planning exactly as it would be without it.
  Rng rng = ctx.rng_ik;
  const auto candidates = graspCandidates(ctx, object);
  long checks = 0;
  for (double margin : graspMargins(ctx.options)) {
    GraspCheckers checkers = graspCheckers(ctx, object, margin);
    int tried = 0;
    for (const GraspCandidate& g : candidates) {
      if (!g.rejected.empty()) break;  // the rest are out of force closure too
      if (tried++ >= ctx.options.max_grasp_candidates) break;
      GraspSolution s;
      if (tryGrasp(ctx, object, g, checkers, ctx.options.approach_distance, rng, s, checks).ok()) return true;
    }
  }
  return false;
}

Failure selectGrasp(TrialContext& ctx, const ObjectState& object, const std::vector<GraspCandidate>& candidates,
                    size_t first, GraspSolution& out, double approach_distance) {
  const TaskOptions& o = ctx.options;
  if (approach_distance < 0) approach_distance = o.approach_distance;
  const double travel = ctx.robot.spec().gripper.travel;
  const auto t = Clock::now();
  StageRecord* st = &ctx.stage("grasp_pose_ik");
  if (ctx.out.target_object < 0) ctx.out.target_object = object.index;
  auto done = [&](const Failure& f) {
    st->compute_seconds = since(t);
    ctx.out.plan_pick_time += st->compute_seconds;
    st->ok = f.ok();
    return f;
  };
  // filterGrasps: the score (force closure), then IK, collision, the approach and the lift; each
  // candidate looked at is recorded with what became of it.
  GraspSelection& sel = ctx.out.grasp_selections.emplace_back();
  sel.object = object.index;
  sel.shape = shapeName(object.shape);
  sel.candidates = static_cast<int>(candidates.size());
  auto note = [&](const GraspCandidate& g, const std::string& result) {
    sel.tried.push_back({graspTypeName(g.type), g.score, g.closure_margin, g.contact_area, g.torque_arm, g.clearance, result});
  };
  if (candidates.empty())
    return done({"grasp_pose_ik", FailureKind::kNoGrasp, "no grasp for this object (tilted, or too wide for the stroke)"});
  Failure last{"grasp_pose_ik", FailureKind::kNoGrasp, "every grasp candidate failed before in this trial"};
  if (!candidates[first < candidates.size() ? first : 0].rejected.empty())
    last = {"grasp_pose_ik", FailureKind::kNoGrasp, "no candidate in force closure: " + candidates[first < candidates.size() ? first : 0].rejected};
  bool found = false;
  for (double margin : graspMargins(o)) {
    // Grasps from the camera's points were cleared at finger_margin: no tight pass for them.
    const bool cloud = fromPoints(candidates[first < candidates.size() ? first : 0].type);
    if (cloud && margin < o.finger_margin) break;
    GraspCheckers checkers = graspCheckers(ctx, object, margin);
    int tried = 0;
    for (size_t c = first; c < candidates.size() && tried < o.max_grasp_candidates; ++c) {
      const GraspCandidate& g = candidates[c];
      if (!g.rejected.empty()) {  // sorted last: none after it is in force closure
        note(g, g.rejected);
        break;
      }
      if (failedBefore(ctx, g)) continue;
      ++tried;
      ++ctx.out.grasp_candidates_tried;
      GraspCandidate chosen = g;
      bool turned = false;
      if (fromPoints(g.type)) {
        // A grasp from the points says how wide it closes: the fingers are checked where they open
        // for it, not at the object's box.
        GraspCheckers own = graspCheckers(ctx, object, margin, g.width / 2);
        last = tryGrasp(ctx, object, g, own, approach_distance, ctx.rng_ik, out, ctx.out.collision_checks);
        if (!last.ok()) {
          // The same grasp with the hand turned half a turn about its approach (the detector gives
          // the turn nearer the home's; the other may be the one the arm reaches, or clears itself
          // in), recorded as the next entry.
          note(g, last.stage + ": " + last.reason);
          turned = true;
          chosen.T_world_tcp.linear() = halfTurnAboutApproach(chosen.T_world_tcp.linear());
          chosen.yaw = yawOf(chosen.T_world_tcp.linear());
          GraspSolution other;
          last = tryGrasp(ctx, object, chosen, own, approach_distance, ctx.rng_ik, other, ctx.out.collision_checks);
          if (last.ok()) out = other;
        }
        ctx.out.collision_checks += own.full->checks() + own.no_target->checks();
      } else {
        last = tryGrasp(ctx, object, g, checkers, approach_distance, ctx.rng_ik, out, ctx.out.collision_checks);
      }
      note(chosen, last.ok() ? "chosen" : last.stage + ": " + last.reason);
      sel.tried.back().turned = turned;
      if (!last.ok()) continue;
      found = true;
      out.object = object;
      out.candidate = chosen;
      out.candidate_index = static_cast<int>(c);
      out.candidates_tried = tried;
      out.approach_distance = approach_distance;
      out.finger_margin = margin;
      out.padding = graspPadding(o, margin, fromPoints(g.type));
      ctx.out.grasp_opening = g.width / 2;
      out.pre_opening = std::min(travel, g.width / 2 + margin);
      break;
    }
    ctx.out.collision_checks += checkers.full->checks() + checkers.no_target->checks();
    if (found) break;
  }
  if (!found) {
    last.reason += " (after " + std::to_string(ctx.out.grasp_candidates_tried) + " grasp candidates)";
    ctx.why_not[object.index] = "grasp: " + last.reason;
    return done(last);
  }
  return done({});
}

Failure planPick(TrialContext& ctx, const GraspSolution& g, Plan& out) {
  const TaskOptions& o = ctx.options;
  const double travel = ctx.robot.spec().gripper.travel;
  const auto t = Clock::now();
  StageRecord& st = ctx.stage("connect_pregrasp");
  auto done = [&](const Failure& f) {
    st.compute_seconds = since(t);
    ctx.out.plan_pick_time += st.compute_seconds;
    return f.ok() ? f : ctx.fail(f);
  };
  PlanningScene full_scene = planningScene(ctx, -1, false);
  const double widest = fromPoints(g.candidate.type) ? g.candidate.width
                                                              : 2 * std::max(g.object.half_size.x(), g.object.half_size.y());
  const double margin = g.finger_margin > 0 ? g.finger_margin : o.finger_margin;
  full_scene.finger_opening = std::min(travel, widest / 2 + margin);
  auto full = wallPaddedChecker(ctx, full_scene, g.padding >= 0 ? g.padding : graspPadding(o, margin, false));
  JointTrajectory t_connect;
  const Failure f = connect(ctx, "connect_pregrasp", *full, full_scene, ctx.q_rest, g.q_pre, t_connect);
  ctx.out.collision_checks += full->checks();
  if (!f.ok()) return done(f);
  const double dt = ctx.hw.period();
  JointTrajectory t_approach = cartesianTrajectory(ctx.robot, g.approach, ikNear(ctx), o.scaling, o.cartesian, dt);
  JointTrajectory t_lift;
  if (!t_approach.empty()) {
    const VecX q_grasped = endOf(t_approach);  // the lift starts where the approach ends
    t_lift = cartesianTrajectory(ctx.robot, g.lift, ikNear(ctx), o.scaling, o.cartesian, dt, &q_grasped);
  }
  if (t_approach.empty() || t_lift.empty())
    return done({t_approach.empty() ? "approach" : "lift", FailureKind::kTimeParameterization,
                 "no smooth time parameterization of the straight line"});
  JointTrajectory connect_whole = blendIntoLine(ctx, t_connect, t_approach, *full);
  // The fingers open to the object's half width plus a margin, not wider: in a bin, the room
  // beside the object is what limits a grasp.
  out = Plan{};
  out.q_start = ctx.q_rest;
  out.name = "pick";
  out.bucket = TimeBucket::kPick;
  out.steps.push_back(gripperStep("open_gripper", ctx.q_rest, g.pre_opening));
  out.steps.push_back(trajectoryStep("move_pregrasp", std::move(t_connect), g.pre_opening, false));
  out.steps.back().stop_path = std::move(connect_whole);
  const VecX q_grasp = endOf(t_approach), q_lifted = endOf(t_lift);
  out.steps.push_back(trajectoryStep("approach", std::move(t_approach), g.pre_opening, false));
  PlanStep close = gripperStep("close_gripper", q_grasp, 0.0);
  close.expected_opening = g.candidate.width / 2;
  out.steps.push_back(close);
  out.steps.push_back(markerStep("attach", PlanStep::Kind::kAttach));
  out.steps.push_back(trajectoryStep("lift", std::move(t_lift), 0.0, true));
  out.q_end = q_lifted;
  out.object = g.object.index;
  out.object_half = g.object.half_size;
  out.object_shape = g.object.shape;
  out.object_pieces = g.object.pieces;
  out.grasp_type = graspTypeName(g.candidate.type);
  out.T_tcp_object = g.T_tcp_object;
  out.T_world_grasp = g.candidate.T_world_tcp;
  out.grasp_candidates_tried = g.candidates_tried;
  if (ctx.faults) ctx.faults->onPlanned(ctx, out);
  return done({});
}

}  // namespace mm
