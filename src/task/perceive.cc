// Perception as the task sees it: the objects in the bin from the configured mode, the target
// chosen by room, the sensor's count of objects in the bin.
#include "task/pick_place.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <tuple>

#include "core/error.h"
#include "planning/blend.h"
#include "planning/chomp.h"
#include "planning/collision.h"
#include "perception/cell_registration.h"
#include "perception/model_pose.h"
#include "perception/segmentation.h"
#include "planning/time_parameterization.h"
#include "sim/hardware.h"
#include "sim/sim_world.h"
#include "task/plan_steps.h"

namespace mm {

// ---- perception ------------------------------------------------------------------------------

namespace {

CellRegistrationOptions registrationOptions(const TrialContext& ctx) {
  CellRegistrationOptions ro;
  ro.T_world_bin = ctx.perception.T_world_crop;
  ro.bin_half = ctx.perception.crop_half;
  ro.depth_sigma_k = ctx.perception.noise.k;
  ro.bin_height = ctx.perception.crop_height;
  return ro;
}

}  // namespace

void removeRobotPoints(const RobotModel& robot, const VecX& q, double finger_opening, const PerceptionOptions& o, Frame& frame) {
  constexpr double kPadding = 0.015;  // [m] the depth's noise and the spheres' fit
  const SphereModel spheres = coverRobot(robot, kPadding);
  std::vector<Pose> T_link;
  robot.linkPoses(q, finger_opening, T_link);
  // The spheres in the world, and the box around them.
  std::vector<Vec3> centre(spheres.local.size());
  Vec3 lo = Vec3::Constant(INFINITY), hi = -lo;
  for (size_t k = 0; k < centre.size(); ++k) {
    centre[k] = T_link[static_cast<size_t>(spheres.link[k])] * spheres.local[k];
    lo = lo.cwiseMin(centre[k] - Vec3::Constant(spheres.radius[k])), hi = hi.cwiseMax(centre[k] + Vec3::Constant(spheres.radius[k]));
  }
  const Pose T_region_world = o.T_world_crop.inverse();
  constexpr double kMargin = 0.05;  // [m] beyond the bin's footprint and height
  // Nothing to do when the robot is nowhere near the region (at home, as it is when it looks).
  Vec3 region_lo = Vec3::Constant(INFINITY), region_hi = -region_lo;
  for (int k = 0; k < 8; ++k) {
    const Vec3 corner = o.T_world_crop * Vec3((k & 1 ? 1 : -1) * (o.crop_half.x() + kMargin), (k & 2 ? 1 : -1) * (o.crop_half.y() + kMargin),
                                              k & 4 ? o.crop_height + kMargin : -kMargin);
    region_lo = region_lo.cwiseMin(corner), region_hi = region_hi.cwiseMax(corner);
  }
  lo = lo.cwiseMax(region_lo), hi = hi.cwiseMin(region_hi);
  if ((lo.array() > hi.array()).any()) return;
  const CameraModel& cam = frame.camera;
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      float& z = frame.depth[static_cast<size_t>(v) * cam.width + u];
      if (!(z > 0)) continue;
      const Vec3 p = cam.unproject(u, v, z);
      if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) continue;
      const Vec3 r = T_region_world * p;
      if (std::abs(r.x()) > o.crop_half.x() + kMargin || std::abs(r.y()) > o.crop_half.y() + kMargin || r.z() > o.crop_height + kMargin) continue;
      for (size_t k = 0; k < centre.size(); ++k)
        if ((p - centre[k]).squaredNorm() <= spheres.radius[k] * spheres.radius[k]) {
          z = 0;
          break;
        }
    }
}

namespace {

// Camera mode: a frame of the perception's camera, its extrinsics those the robot holds: the
// calibration file's, else the mount's in the scene, corrected by the last registration against
// the cell. The faults that strike frames (a blackout, a dropout) strike those perception reads.
// `self_filter`: the robot's own points taken out (removeRobotPoints), for the readers that take
// missing depth for nothing there (the segmentation, the model-free grasps); the known objects'
// fitter counts missing depth as a blackout, so it reads the view as it is.
bool captureFrame(TrialContext& ctx, Frame& frame, std::string* why, bool for_perception, bool self_filter) {
  const PerceptionOptions& o = ctx.perception;
  if (ctx.faults) ctx.faults->beforeCapture(ctx, o.camera);
  if (!ctx.hw.capture(o.camera, o.camera_width, o.camera_height, frame, why)) {
    *why = "camera '" + o.camera + "': " + *why;
    return false;
  }
  if (ctx.faults && for_perception) ctx.faults->onFrame(ctx, frame);
  if (o.calibrated) frame.camera.T_world_camera = o.T_world_camera;  // where calibration says it is
  if (ctx.T_extrinsics_registered) frame.camera.T_world_camera = frame.camera.T_world_camera * *ctx.T_extrinsics_registered;
  // The robot's own points out (what it measures of itself, not the simulator's truth).
  if (self_filter && o.crop_half.x() > 0) removeRobotPoints(ctx.robot, ctx.hw.jointPositions(), ctx.hw.gripperOpening(), o, frame);
  return true;
}

}  // namespace

bool captureView(TrialContext& ctx, Frame& frame, std::string* why) { return captureFrame(ctx, frame, why, true, true); }

namespace {

// Known models' poses scored as the BOP Challenge's targets: each true object in the bin of a kind
// with a model, its visible fraction its pixels in the view (the renderer's labels) over its
// model's drawn alone at its pose (however much of it falls outside the image); those at least 0.1
// visible are the view's targets. Each is matched to a detection posed by its own model: every
// such pair by its MSSD, the least first, each target and each detection once (BOP matches per
// threshold by the error; this match is the one every threshold reads). The truth's side is drawn
// from where the camera really was (`real`); `depth` is the view's, as the robot saw it.
void scorePoses(const std::vector<float>& depth, const ScoringView& real, const PerceptionOptions& o, const std::vector<ObjectState>& truth,
                const std::vector<ObjectState>& detections, const std::vector<int>& posed_by, PoseViewRecord& view) {
  const ModelPoseEstimator& models = *o.models;
  const CameraModel& cam = real.camera;
  if (real.labels.size() != depth.size() || depth.empty()) return;  // no labels rendered: nothing to score by
  std::array<long, 256> seen{};
  for (uint8_t l : real.labels) ++seen[l];
  static const std::vector<double> kTaus{0.05, 0.10, 0.15, 0.20, 0.25, 0.30, 0.35, 0.40, 0.45, 0.50};
  constexpr double kDelta = 0.015;  // [m] BOP's VSD tolerance for most datasets
  constexpr int kLastLabelled = kSegmentObstacle - kSegmentObject0 - 2;  // objects past it share a label
  struct Target {
    const ObjectState* truth;
    const ObjectModel* model;
    int model_index;
    PoseTargetRecord record;
  };
  std::vector<Target> targets;
  for (const ObjectState& t : truth) {
    int k = -1;
    for (size_t j = 0; j < models.models().size(); ++j)
      if (t.pieces && models.models()[j]->pieces == t.pieces) k = static_cast<int>(j);
    // The bin's objects only (those in the tray are seen, never looked for).
    if (k < 0 || t.index < 0 || t.index > kLastLabelled || !insideCrop(t, o)) continue;
    const ObjectModel& m = *models.models()[static_cast<size_t>(k)];
    const std::array<int, 4> w = modelWindow(m, t.T_world_object, cam, false);
    const ModelDrawing alone = drawModel(m, t.T_world_object, cam, w[0], w[1], w[2], w[3]);
    const long all = std::count_if(alone.depth.begin(), alone.depth.end(), [](float z) { return z > 0; });
    if (all == 0) continue;
    PoseTargetRecord r;
    r.object = t.index;
    r.visible_fraction = std::min(1.0, static_cast<double>(seen[static_cast<size_t>(kSegmentObject0 + t.index)]) / all);
    if (r.visible_fraction < 0.1) continue;
    r.diameter = m.diameter;
    targets.push_back({&t, &m, k, std::move(r)});
  }
  std::vector<std::tuple<double, size_t, size_t>> pairs;  // MSSD, target, detection
  for (size_t i = 0; i < targets.size(); ++i)
    for (size_t d = 0; d < detections.size() && d < posed_by.size(); ++d)
      if (posed_by[d] == targets[i].model_index)
        pairs.emplace_back(mssd(*targets[i].model, detections[d].T_world_object, targets[i].truth->T_world_object), i, d);
  std::sort(pairs.begin(), pairs.end());
  std::vector<char> detection_used(detections.size(), 0);
  for (const auto& [e, i, d] : pairs) {
    Target& g = targets[i];
    if (g.record.posed || detection_used[d]) continue;
    detection_used[d] = 1;
    const Pose& est = detections[d].T_world_object;
    g.record.posed = true;
    g.record.mssd = e;
    g.record.mspd = mspd(*g.model, est, g.truth->T_world_object, cam);
    g.record.vsd = vsd(*g.model, est, g.truth->T_world_object, cam, depth, kDelta, kTaus);
  }
  for (Target& g : targets) view.targets.push_back(std::move(g.record));
}

// Camera mode: the camera's depth image through detectKnownObjects, or, for objects with no model,
// cut into segments (segmentDepth, segmentObject). Every detection is what the robot knows, under
// an id of its own; a false one included (the robot finds out by trying). The simulator's truth
// only scores it afterwards: each detection is matched to the true object nearest it (within 3 cm;
// a segment, within its footprint's half diagonal) for its pose errors and the trial's bookkeeping (truth_of), a detection
// near none is recorded as false, an object in the bin no detection found as missed.
PerceptionResult perceiveByCamera(TrialContext& ctx) {
  const PerceptionOptions& o = ctx.perception;
  PerceptionResult p;
  Frame frame;
  std::string why;
  if (!captureFrame(ctx, frame, &why, true, o.unknown_objects)) {
    p.reason = why;
    return p;
  }
  // The camera where its extrinsics put it, as the cell's known parts see it (the registration,
  // started from the extrinsics). A frame with too little depth to tell (a blackout) is left to the
  // perception, which refuses it for its own reasons.
  if (o.max_extrinsics_error > 0) {
    const CellRegistration check = registerCameraToCell(frame, ctx.statics, checkOptions(registrationOptions(ctx)));
    char buf[300];
    if (!check.ok && !check.blind) {
      p.reason = "the camera cannot be checked against the cell's known parts (" + check.reason + "): it may have moved";
      return p;
    }
    const double error = check.ok ? check.bin_shift : 0.0;
    if (error > o.max_extrinsics_error) {
      std::snprintf(buf, sizeof buf, "the cell's known parts put the camera %.2f deg and %.1f mm from its extrinsics, which moves "
                    "what it sees in the bin by up to %.1f mm: it has moved (register it again)", check.rotation * 180 / M_PI,
                    1e3 * check.translation, 1e3 * error);
      p.reason = buf;
      return p;
    }
  }
  CameraPerceptionResult r;
  std::vector<int> posed_by;  // each detection's model (known_models), or -1: a segment's columns
  PoseViewRecord pose_view;   // known_models: the view's pose estimation
  pose_view.time = ctx.simTime();
  pose_view.width = frame.camera.width;
  if (o.unknown_objects) {  // no model: each segment of the depth, as the columns under its points
    const SegmentationOptions so = segmentationOptions(o);
    const Segmentation segments = o.segmentation == SegmentationSource::kLabels ? segmentLabels(frame, so) : segmentDepth(frame, so);
    // Known objects: the segments posed by their models (the pixels a pose explains are its; what
    // it leaves of its segment is posed again), each known as the model it is; what no model
    // explains stays an unknown object.
    ViewPoses view_poses;
    const std::vector<Segment>* unknown = &segments.segments;
    if (o.known_models && o.models) {
      view_poses = o.models->estimateView(frame, segments.segments, so);
      pose_view.segments = view_poses.estimates;
      pose_view.posed = static_cast<int>(view_poses.poses.size());
      pose_view.seconds = view_poses.seconds;
      for (const ModelPose& mp : view_poses.poses) {
        const ObjectModel& m = *o.models->models()[static_cast<size_t>(mp.model)];
        ObjectState ob;
        ob.T_world_object = mp.T_world_object;
        ob.shape = ObjectShape::kMesh;
        ob.half_size = m.half_size;
        ob.mass = m.mass;
        ob.pieces = m.pieces;
        r.detections.push_back({ob});
        posed_by.push_back(mp.model);
      }
      unknown = &view_poses.unknown;
    }
    for (const Segment& s : *unknown) {
      r.detections.push_back({segmentObject(s, o.T_world_crop)});
      posed_by.push_back(-1);
    }
    if (ctx.keep_view) {  // for a picture (render.images: segments)
      auto labels = std::make_shared<std::vector<uint16_t>>(frame.depth.size(), 0);
      uint16_t k = 0;
      for (const std::vector<Segment>* list : {static_cast<const std::vector<Segment>*>(&view_poses.explained), unknown})
        for (const Segment& s : *list) {
          ++k;
          for (int pixel : s.pixels) (*labels)[static_cast<size_t>(pixel)] = k;
        }
      Frame view;
      view.camera = frame.camera;
      view.depth = frame.depth;
      ctx.last_view = std::make_shared<const Frame>(std::move(view));
      ctx.last_segments = std::move(labels);
      ctx.last_grasp.reset();  // the grasp drawn over a view is one chosen after it (from the camera's next capture)
    }
    // What no segment explains (a patch too small to be an object) is avoided as its columns.
    for (const std::vector<Segment>* list : {&segments.small, static_cast<const std::vector<Segment>*>(&view_poses.small)})
      for (const Segment& s : *list)
        for (Obstacle& column : obstaclesOf(segmentObject(s, o.T_world_crop))) {
          column.name = "unexplained_" + std::to_string(r.unexplained.size());
          r.unexplained.push_back(std::move(column));
        }
    r.ok = true;
  } else {
    CameraPerceptionOptions co;
    co.T_world_crop = o.T_world_crop;
    co.crop_half = o.crop_half;
    co.crop_height = o.crop_height;
    co.depth_sigma_k = o.noise.k;  // the sensor's datasheet: the noise the experiment gives it
    co.max_missing = o.max_missing_depth;
    r = detectKnownObjects(frame, o.shapes, co, ctx.rng_perception);
  }
  ctx.seen_obstacles = r.unexplained;  // what the camera saw and could not explain: avoided, not hit
  for (const CameraDetection& d : r.detections) {
    ObjectState seen = d.object;
    seen.index = ctx.next_detection_id++;
    seen.name = "detection_" + std::to_string(seen.index);
    p.objects.push_back(seen);
  }
  {
    const TruthScope scoring(ctx.hw, "scoring the detections");
    std::vector<ObjectState> truth;
    for (const ObjectState& t : ctx.hw.objects())
      if (t.index != ctx.held_truth) truth.push_back(t);
    std::vector<char> taken(truth.size(), 0);
    for (size_t d = 0; d < p.objects.size(); ++d) {
      const ObjectState& seen = p.objects[d];
      const int model = d < posed_by.size() ? posed_by[d] : -1;
      const bool segment = o.unknown_objects && model < 0;
      int best = -1;
      // A model's detection is matched within 3 cm of its object; a segment's box, within its
      // footprint's half diagonal (its centre is its points', not the object's).
      double best_dist = segment ? std::max(0.03, seen.half_size.head<2>().norm()) : 0.03;
      for (size_t i = 0; i < truth.size(); ++i) {
        const double dist = (truth[i].T_world_object.translation() - seen.T_world_object.translation()).norm();
        if (!taken[i] && dist < best_dist) best = static_cast<int>(i), best_dist = dist;
      }
      DetectionRecord rec;
      rec.time = ctx.simTime();
      if (best < 0) {
        rec.centre_error = rec.rotation_error = rec.mssd = -1;
        ctx.truth_of[seen.index] = -1;
      } else {
        taken[static_cast<size_t>(best)] = 1;
        const ObjectState& t = truth[static_cast<size_t>(best)];
        rec.object = t.index;
        if (model >= 0) {
          // Posed by a model: BOP's MSSD over the model's symmetries, when it is the object's own
          // (else the pose has no error to speak of: -1, as a false one's).
          const ObjectModel& m = *o.models->models()[static_cast<size_t>(model)];
          rec.centre_error = (seen.T_world_object.translation() - t.T_world_object.translation()).norm();
          rec.rotation_error = rec.mssd = -1;
          if (t.pieces == m.pieces) {
            rec.mssd = mssd(m, seen.T_world_object, t.T_world_object);
            double angle = M_PI;
            for (const Mat3& S : m.symmetries)
              angle = std::min(angle, angleBetween(seen.T_world_object.linear(), t.T_world_object.linear() * S));
            rec.rotation_error = angle;
          }
        } else {
          const PoseError e = poseError(seen.T_world_object, t.T_world_object, t.half_size, t.shape);
          rec.centre_error = e.centre, rec.rotation_error = e.rotation, rec.mssd = e.mssd;
          if (segment) rec.rotation_error = rec.mssd = -1;  // a segment's columns have no orientation of the object's
        }
        ctx.truth_of[seen.index] = t.index;
      }
      ctx.out.detections.push_back(rec);
    }
    for (size_t i = 0; i < truth.size(); ++i)
      if (!taken[i] && insideCrop(truth[i], o)) ++ctx.out.missed_detections;
    if (o.known_models && o.models) {
      if (const ScoringView* real = ctx.scoringView(scoring)) scorePoses(frame.depth, *real, o, truth, p.objects, posed_by, pose_view);
      ctx.out.pose_views.push_back(std::move(pose_view));
    }
  }
  p.ok = !p.objects.empty();
  if (!p.ok && !r.unexplained.empty())
    p.reason = "nothing recognised, but unexplained points rise above the bin floor (" + std::to_string(r.unexplained.size()) + " box(es) of them)";
  else if (!p.ok)
    p.reason = r.ok ? "no object detected" : r.reason;
  return p;
}

}  // namespace

Failure detectObjects(TrialContext& ctx) {
  StageRecord& st = ctx.stage("perception");
  const auto t = Clock::now();
  PerceptionResult p;
  if (ctx.perception.mode == PerceptionMode::kCamera) {
    p = perceiveByCamera(ctx);
  } else {  // the simulator is the sensor (or, hardcoded, nothing is)
    std::vector<ObjectState> truth;
    for (const ObjectState& o : ctx.hw.objects())
      if (o.index != ctx.held) truth.push_back(o);
    p = perceive(truth, ctx.perception, ctx.rng_perception);
  }
  if (ctx.faults) ctx.faults->onPerception(ctx, p);
  ctx.senseObstacles();
  st.compute_seconds = since(t);
  ctx.out.perception_time += st.compute_seconds;
  if (!p.ok) return ctx.fail({"perception", FailureKind::kPerception, p.reason});
  ctx.milestone("perception");
  const bool first = ctx.objects.empty() && ctx.picked.empty();
  ctx.objects = p.objects;
  if (first) ctx.out.objects_in_bin = static_cast<int>(ctx.objects.size());
  return {};
}

Failure registerCamera(TrialContext& ctx) {
  const PerceptionOptions& o = ctx.perception;
  if (o.mode != PerceptionMode::kCamera) return {};  // the simulator is the sensor: no camera to register
  StageRecord& st = ctx.stage("registration");
  const auto t = Clock::now();
  Frame frame;
  std::string why;
  CellRegistration r;
  if (captureFrame(ctx, frame, &why, false, false)) {
    r = registerCameraToCell(frame, ctx.statics, registrationOptions(ctx));
  } else {
    r.reason = why;
  }
  st.compute_seconds = since(t);
  ctx.out.perception_time += st.compute_seconds;
  if (!r.ok) return ctx.fail({"registration", FailureKind::kPerception, "registering the camera against the cell: " + r.reason});
  // The correction of the extrinsics held without one (the frame's, less the last correction).
  Pose base = frame.camera.T_world_camera;
  if (ctx.T_extrinsics_registered) base = base * ctx.T_extrinsics_registered->inverse();
  ctx.T_extrinsics_registered = base.inverse() * r.T_world_camera;
  ctx.out.camera_registrations.push_back(
      {ctx.simTime(), r.rotation, r.translation, r.bin_shift, r.rms, r.points});
  ctx.milestone("registration");
  return {};
}

std::vector<int> objectsByRoom(const TrialContext& ctx) {
  std::vector<std::pair<double, int>> order;
  for (size_t i = 0; i < ctx.objects.size(); ++i) {
    const ObjectState& a = ctx.objects[i];
    if (picked(ctx, a.index)) continue;
    double room = 1.0;
    for (const ObjectState& b : ctx.objects)
      if (a.index != b.index && !picked(ctx, b.index))
        room = std::min(room, (a.T_world_object.translation() - b.T_world_object.translation()).head<2>().norm());
    order.push_back({room, static_cast<int>(i)});
  }
  // Objects seen whole first (a face partly hidden under another gives a less sure pose, and what
  // hides it is usually better taken first), then by room.
  auto whole = [&](int i) { return ctx.objects[static_cast<size_t>(i)].seen >= 0.9; };
  std::stable_sort(order.begin(), order.end(), [&](const auto& x, const auto& y) {
    if (whole(x.second) != whole(y.second)) return whole(x.second);
    return x.first > y.first;
  });
  std::vector<int> out;
  for (const auto& [room, i] : order) out.push_back(i);
  return out;
}

int mostAccessibleObject(TrialContext& ctx) {
  const std::vector<int> order = objectsByRoom(ctx);
  for (int i : order)
    if (graspable(ctx, ctx.objects[i])) return i;
  return order.empty() ? -1 : order.front();
}

int perceivedObjectAt(const TrialContext& ctx, const Pose& T_world_object) {
  int best = -1;
  double best_d = 0.05;
  for (size_t i = 0; i < ctx.objects.size(); ++i) {
    const double d = (ctx.objects[i].T_world_object.translation() - T_world_object.translation()).norm();
    if (d <= best_d && !picked(ctx, ctx.objects[i].index)) best_d = d, best = static_cast<int>(i);
  }
  return best;
}

int objectsInBin(TrialContext& ctx) {
  if (ctx.perception.mode != PerceptionMode::kCamera) return objectsInBinTruly(ctx);  // the simulator is the sensor
  // Camera mode: the objects the robot saw and has not picked; when it knows of none, it looks
  // again (once a pick: a detection it missed, an object dropped back in).
  int n = 0;
  for (const ObjectState& o : ctx.objects) n += !picked(ctx, o.index);
  if (n > 0) return n;
  if (ctx.looked_at_picks == static_cast<int>(ctx.picked.size())) return static_cast<int>(ctx.seen_obstacles.size());
  ctx.looked_at_picks = static_cast<int>(ctx.picked.size());
  const auto t = Clock::now();
  PerceptionResult p = perceiveByCamera(ctx);
  ctx.out.perception_time += since(t);
  if (ctx.faults) ctx.faults->onPerception(ctx, p);
  // Not empty while something the camera cannot explain rises above the floor: the robot cannot
  // pick it, but it must not call the bin empty (the trial ends on the failure to perceive it).
  if (!p.ok) return static_cast<int>(ctx.seen_obstacles.size());
  ctx.objects = p.objects;
  return static_cast<int>(p.objects.size());
}

int objectsInBinTruly(const TrialContext& ctx) {
  const TruthScope scoring(ctx.hw, "the bin as it is");
  int n = 0;
  for (const ObjectState& o : ctx.hw.objects())
    if (o.index != ctx.held_truth && insideCrop(o, ctx.perception)) ++n;
  return n;
}

}  // namespace mm
