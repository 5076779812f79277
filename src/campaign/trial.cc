#include "campaign/trial.h"

#include <chrono>
#include <cstdio>
#include <filesystem>

#include "bt/sqlite_log.h"
#include "core/error.h"
#include "perception/calibration.h"
#include "perception/model_pose.h"
#include "bt/trial_runner.h"
#include "render/image_io.h"
#include "render/renderer.h"
#include "render/trial_renders.h"
#include "sim/hardware.h"
#include "sim/sim_world.h"
#include "task/external_component.h"
#include "task/pick_place.h"

namespace mm {

TrialRunner::TrialRunner(const Experiment& e, const Cell& cell, const bt::TreeDocument& tree, std::string log_dir,
                         std::string date)
    : e_(e), cell_(cell), doc_(tree), needs_camera_(needsCamera(e, tree)), log_dir_(std::move(log_dir)), date_(std::move(date)) {
  env_.T_world_place_target = cell.T_world_place_target;
  bt::registerTaskNodes(factory_, env_);
  // The component's stderr beside the campaign's results (its workers append to the one file).
  if (usesExternal(e, tree))
    external_ = std::make_unique<ExternalComponent>(e.task.external, std::filesystem::path(log_dir_).parent_path() / "external_stderr.log");
}

TrialRunner::~TrialRunner() = default;

void TrialRunner::replayExternal(std::vector<ExternalCallRecord> calls) {
  if (external_) external_->replay(std::move(calls));
}

void TrialRunner::setRenderer(Renderer* renderer, std::string dir, const RenderOptions& options) {
  renderer_ = renderer;
  render_dir_ = std::move(dir);
  render_ = options;
}

RenderSetup::RenderSetup() = default;
RenderSetup::~RenderSetup() = default;
RenderSetup::RenderSetup(RenderSetup&&) noexcept = default;

RenderSetup setUpRendering(const Experiment& e) {
  RenderSetup r;
  r.options = e.render;
  if (!e.render.enabled() && !needsCamera(e)) return r;
  std::string why;
  r.renderer = Renderer::create(e.render.egl, &why);
  if (!r.renderer) {
    std::fprintf(stderr, "minimanip: rendering off, the trials run without images: %s\n", why.c_str());
    return r;
  }
  if (r.options.video && !VideoWriter::available(&why)) {
    std::fprintf(stderr, "minimanip: no videos (%s); key frames only\n", why.c_str());
    r.options.video = false;
  }
  return r;
}

std::string trialRenderDir(const std::string& dir, uint64_t trial) {
  char name[32];
  std::snprintf(name, sizeof name, "trial_%06lu", static_cast<unsigned long>(trial));
  return (std::filesystem::path(dir) / name).string();
}

namespace {

// The fingers of the last grasp the robot executed a pick with, as open as its plan opened them,
// as boxes in the world (pictures); none before the first.
std::vector<WorldBox> fingersOf(const TrialContext& ctx, const GraspOptions& hand) {
  std::vector<WorldBox> boxes;
  if (!ctx.last_grasp) return boxes;
  const double open = ctx.last_grasp->opening;
  for (int side = -1; side <= 1; side += 2) {
    WorldBox b;
    b.half = Vec3(hand.pad_half_width, hand.finger_thickness / 2, (hand.pad_z_max - hand.pad_z_min) / 2);
    b.T_world_box = ctx.last_grasp->T_world_tcp * makePose(Vec3(0, side * (open + b.half.y()), (hand.pad_z_max + hand.pad_z_min) / 2), Mat3::Identity());
    boxes.push_back(b);
  }
  return boxes;
}

}  // namespace

TrialOutcome TrialRunner::run(Hardware& backend, SimWorld& world, uint64_t trial, std::string& bt_log) {
  using Clock = std::chrono::steady_clock;
  std::unique_ptr<FaultInjector> faults;
  if (e_.faults.any()) faults = std::make_unique<FaultInjector>(e_.faults, world, e_.seed, trial);
  // Renders: a key frame as a listed stage ends (seen before the next control period, or at the
  // end, so the world is as the stage left it), video frames after control periods.
  std::unique_ptr<TrialRenders> renders;
  const TrialContext* context = nullptr;
  size_t stages_seen = 0;
  const GraspOptions hand = graspOptionsFor(cell_.robot->spec().gripper, e_.task);
  auto stages_ended = [&](bool all) {
    const std::vector<StageRecord>& s = context->out.stages;
    while (stages_seen + (all ? 0 : 1) < s.size()) {
      if (renders->wantsSegments() && context->last_view) renders->setSegments(context->last_view, context->last_segments, fingersOf(*context, hand));
      renders->stageEnded(s[stages_seen++].name);
    }
  };
  rendered_.clear();
  if (renderer_ && render_.renders(trial))
    renders = std::make_unique<TrialRenders>(*renderer_, world, render_, trialRenderDir(render_dir_, trial), e_.file);
  // Camera perception reads depth images rendered now, with the sensor's noise drawn from the
  // trial's own stream.
  Rng camera_noise = Rng::stream(e_.seed, trial, Purpose::kCamera);
  ScoringView scoring_view;
  if (renderer_ && needs_camera_)
    backend.setCameraSource([&](const std::string& name, int width, int height, Frame& frame, std::string*) {
      // The oracle's segmentation reads the renderer's labels (perception.segmentation: labels).
      // The external component's declared oracle run is given them too (external.oracle); colour for it always.
      // Known models' poses are scored by them (their visible fractions): then they are kept apart,
      // out of the frame, for the scoring alone (TrialContext::scoringView), with where the camera
      // really drew from.
      const bool labels = e_.perception.segmentation == SegmentationSource::kLabels || (external_ && e_.task.external.oracle);
      const bool scoring = !labels && e_.perception.known_models;
      const unsigned kinds = (labels || scoring ? kDepth | kSegmentation : kDepth) | (external_ ? kRgb : 0u);
      frame = renderer_->render(world, renderer_->camera(world, name, width, height, e_.file), kinds);
      scoring_view.camera = frame.camera;
      scoring_view.camera.T_world_camera = frame.camera.T_world_camera * world.cameraOffset(name);
      scoring_view.labels.clear();
      if (scoring) scoring_view.labels.swap(frame.segmentation);
      else if (e_.perception.known_models) scoring_view.labels = frame.segmentation;  // the oracle's, given on purpose
      applyDepthNoise(frame, e_.perception.noise, camera_noise);
      if (view_tap_) view_tap_(world, frame);
      return true;
    });
  Hardware& tapped = renders ? renders->wrap(backend, [&] { stages_ended(false); }) : backend;
  const bool keep_view = renders && renders->wantsSegments();
  Hardware& hw = faults ? faults->wrap(tapped) : tapped;
  TrialContext ctx(hw, *cell_.robot, cell_.statics, e_.task, cell_.perception, e_.seed, trial);
  ctx.target_half_height = cell_.place_target_half_height;
  ctx.keep_view = keep_view;
  context = &ctx;
  ctx.setScoringView(&scoring_view);
  ctx.faults = faults.get();
  ctx.external = external_.get();
  if (external_) external_->beginTrial();
  env_.ctx = &ctx;
  std::unique_ptr<bt::Tree> tree = factory_.instantiate(doc_);
  tree->rootBlackboard().set("place_target", bt::toAny(cell_.T_world_place_target));
  std::unique_ptr<bt::TransitionRecorder> recorder;
  if (e_.bt_log != "none") recorder = std::make_unique<bt::TransitionRecorder>(*tree);
  const bt::TreeRunResult r = bt::runTree(*tree, ctx, e_.tree_run);
  const bool succeeded = r.status == bt::NodeStatus::kSuccess && !r.timeout && r.error.empty();
  finishTrial(ctx, succeeded);
  if (renders) {
    stages_ended(true);
    rendered_ = renders->finish();
  }
  if (faults) ctx.out.faults = faults->report(ctx);
  env_.ctx = nullptr;
  TrialOutcome out = std::move(ctx.out);
  out.tree = tree->mainTreeId();
  out.ik_solver = ctx.ik->name();
  out.tree_status = r.timeout ? "TIMEOUT" : !r.error.empty() ? "ERROR" : bt::toString(r.status);
  out.ticks = r.ticks;
  cost_.tick_seconds += r.tick_wall_seconds;
  cost_.leaf_seconds += r.leaf_wall_seconds;
  for (const StageRecord& s : out.stages) cost_.compute_seconds += s.compute_seconds;
  cost_.ticks += r.ticks;
  bt_log.clear();
  if (recorder) {
    cost_.transitions += static_cast<long>(recorder->transitions().size());
    const bool keep = e_.bt_log == "all" || !out.success || out.recovery_needed;
    if (keep) {
      const auto t0 = Clock::now();
      if (xml_.empty()) xml_ = factory_.treeToXml(*tree);
      char name[64];
      std::snprintf(name, sizeof name, "trial_%06lu.db3", static_cast<unsigned long>(trial));
      bt_log = (std::filesystem::path(log_dir_) / name).string();
      recorder->write(bt_log, *tree, date_, xml_);
      cost_.log_seconds += std::chrono::duration<double>(Clock::now() - t0).count();
      ++cost_.logs;
    }
  }
  return out;
}

std::unique_ptr<SimWorld> loadWorld(const Experiment& e, const RobotModel& robot) {
  auto world = SimWorld::load(e.scene_path, robot);
  world->setPhysics(e.physics, e.file);
  return world;
}

Cell makeCell(const Experiment& e, const RobotModel& robot, const SimWorld& world) {
  Cell c;
  c.robot = &robot;
  c.statics = world.staticObstacles();
  const auto [T_bin, bin_half] = world.site("bin_region");
  const auto [T_place, place_half] = world.site("place_target");
  // The place target's height and the hardcoded perception's object: the first kind's.
  c.spawn = e.spawn;
  c.spawn.resolve(e.file);
  ObjectState proto;
  proto.half_size = c.spawn.loaded.find(c.spawn.kinds.front())->half_size;
  c.T_world_bin = T_bin;
  c.bin_half = bin_half;
  c.T_world_place_target = T_place;
  c.T_world_place_target.translation().z() += proto.half_size.z();
  c.place_target_half_height = proto.half_size.z();
  c.perception = e.perception;
  c.perception.hardcoded_pose = makePose(T_bin.translation() + Vec3(0, 0, proto.half_size.z()), Mat3::Identity());
  c.perception.hardcoded_half = proto.half_size;
  c.perception.T_world_crop = T_bin;
  if (e.perception.mode == PerceptionMode::kCamera && e.perception.extrinsics != "simulator") {
    std::string camera;
    c.perception.T_world_camera = readExtrinsics(e.perception.extrinsics, &camera);
    c.perception.calibrated = true;
    if (camera != e.perception.camera)
      throw InputError(e.perception.extrinsics, "calibrates camera '" + camera + "', expected perception.camera '" + e.perception.camera + "'");
  }
  // Generated objects and meshes have no model the camera's perception fits: it segments them.
  c.perception.unknown_objects = c.spawn.generated.enabled();
  // What a generated object can measure seen from above: no side of its bounding box is longer than
  // max_extent, along or across (max_width bounds a piece the fingers close across, not the
  // outline: a ring or a cup is as wide as it is long).
  if (c.spawn.generated.enabled()) c.perception.object_length = c.perception.object_width = c.spawn.generated.max_extent;
  for (const std::string& k : c.spawn.kinds) {
    const ObjectKind* kind = c.spawn.loaded.find(k);
    if (kind->shape == ObjectShape::kMesh) c.perception.unknown_objects = true;
    c.perception.shapes.push_back({kind->name, kind->half_size, kind->mass, kind->shape});
  }
  // Known objects: the mesh kinds' models (their visual meshes, symmetries, collision pieces and
  // mass: what a real cell holds of its parts), their point-pair tables built once per cell.
  if (e.perception.known_models) {
    if (e.perception.mode != PerceptionMode::kCamera)
      throw InputError(e.file, "perception.known_models: expected perception.mode camera (the models pose what the camera sees)");
    std::vector<std::shared_ptr<const ObjectModel>> models;
    for (const std::string& k : c.spawn.kinds) {
      const ObjectKind* kind = c.spawn.loaded.find(k);
      if (kind->shape != ObjectShape::kMesh) continue;
      auto m = std::make_shared<ObjectModel>(
          ObjectModel::fromMesh(kind->name, kind->solid->visual_vertices, kind->solid->visual_faces, kind->symmetries));
      m->pieces = kind->solid->pieces, m->half_size = kind->half_size, m->mass = kind->mass;
      models.push_back(std::move(m));
    }
    if (models.empty())
      throw InputError(e.file, "perception.known_models: expected mesh or URDF kinds among objects.kinds (the models come from their meshes)");
    ModelPoseOptions mo;
    mo.depth_sigma_k = e.perception.noise.k;
    c.perception.models = std::make_shared<const ModelPoseEstimator>(std::move(models), mo);
  }
  c.perception.crop_half = bin_half;
  // What the sensor looks at rises to three of the tallest kind (a pile stacks them), unless given.
  if (c.perception.crop_height <= 0) {
    double tallest = 0;
    for (const std::string& k : c.spawn.kinds) tallest = std::max(tallest, 2 * c.spawn.loaded.find(k)->half_size.maxCoeff());
    if (c.spawn.generated.enabled()) tallest = std::max(tallest, c.spawn.generated.max_extent);
    c.perception.crop_height = std::max(0.1, 3 * tallest);
  }
  return c;
}

std::string nodeLibraryMarkdown() {
  bt::Factory f;
  bt::TaskNodeEnv env;
  bt::registerTaskNodes(f, env);
  std::string md = "| node | kind | ports | meaning |\n|---|---|---|---|\n";
  for (const auto& [id, m] : f.manifests()) {
    if (f.isBuiltin(id)) continue;
    std::string ports;
    for (const auto& [name, p] : m.ports) {
      const char* dir = p.direction == bt::PortDirection::kInput ? "in" : p.direction == bt::PortDirection::kOutput ? "out" : "in/out";
      ports += (ports.empty() ? "" : "<br>") + std::string("`") + name + "` (" + dir + ", " +
               (p.type.stronglyTyped() ? p.type.name : "any") + (p.default_value ? ", default " + *p.default_value : "") +
               ")" + (p.description.empty() ? "" : ": " + p.description);
    }
    md += "| `" + id + "` | " + bt::toString(m.kind) + " | " + (ports.empty() ? "-" : ports) + " | " + m.description + " |\n";
  }
  return md;
}

bt::TreeDocument loadTree(const Experiment& e) {
  bt::Factory f;
  bt::TaskNodeEnv env;
  bt::registerTaskNodes(f, env);
  return f.load(e.tree_path);
}

}  // namespace mm
