#include "bench/harness_bench.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>
#include <unistd.h>

#include "campaign/stats.h"
#include "campaign/trial.h"
#include "core/error.h"
#include "grasp/cloud_grasps.h"
#include "perception/camera_perception.h"
#include "perception/cell_registration.h"
#include "perception/segmentation.h"
#include "planning/collision.h"
#include "render/renderer.h"
#include "sim/hardware.h"
#include "sim/sim_world.h"

namespace mm {

std::string benchmarkHarness(const Experiment& experiment, const std::string& command_line) {
  if (experiment.hardware != "mujoco") throw InputError(experiment.file, "the harness benchmark needs hardware: mujoco");
  if (experiment.perception.mode == PerceptionMode::kCamera)
    throw InputError(experiment.file, "the harness benchmark runs ground-truth or hardcoded perception (it times camera perception "
                                      "itself, with the experiment's perception.camera settings)");
  Experiment e = experiment;
  e.bt_log = "all";  // the tree's cost is measured with every trial's SQLite log written
  const RobotModel robot = loadExperimentRobot(e);
  auto world = loadWorld(e, robot);
  const Cell cell = makeCell(e, robot, *world);
  const bt::TreeDocument tree = loadTree(e);
  const std::filesystem::path logs = std::filesystem::temp_directory_path() / ("minimanip_bench_" + std::to_string(getpid()));
  std::filesystem::create_directories(logs);
  TrialRunner runner(e, cell, tree, logs.string(), "2000-01-01 00:00:00");
  using Clock = std::chrono::steady_clock;
  auto secs = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); };

  double wall_full = 0, wall_tree = 0, wall_chain = 0, sim_task = 0, wall_replay = 0, sim_replay = 0;
  double wall_pool = 0, sim_pool = 0;  // the same controls on the old model: six cubes, those out of play parked
  SimWorld::ReplayCounts counts_new, counts_pool;
  SpawnOptions pooled = cell.spawn;
  pooled.pool = std::max(6, cell.spawn.count_max);
  long ok = 0, same = 0, steps = 0, trials = 0;
  std::vector<double> ratio;  // per trial: tree wall / chain wall
  std::vector<double> log;
  const auto t_all = Clock::now();
  for (int64_t i = 0; i < e.trials; ++i) {
    // The same trial three ways, back to back: through the tree (with its log written), through
    // the tree-less chain of the same actions, and as bare MuJoCo stepping of the tree run's controls.
    const auto t0 = Clock::now();
    Rng rng = Rng::stream(e.seed, i, Purpose::kScene);
    const SpawnResult spawn = spawnObjects(*world, robot, cell.T_world_bin, cell.bin_half, rng, cell.spawn);
    if (!spawn.ok) continue;
    ++trials;
    const SimWorld::State start = world->saveState();
    log.clear();
    world->recordControls(&log);
    auto hw = makeMujocoHardware(*world, robot, spawn.active);
    const auto t1 = Clock::now();
    std::string bt_log;
    const TrialOutcome by_tree = runner.run(*hw, *world, static_cast<uint64_t>(i), bt_log);
    const auto t2 = Clock::now();
    world->recordControls(nullptr);
    ok += by_tree.success;
    wall_full += secs(t0, t2);
    wall_tree += secs(t1, t2);
    sim_task += world->time() - start.time;

    Rng rng2 = Rng::stream(e.seed, i, Purpose::kScene);
    spawnObjects(*world, robot, cell.T_world_bin, cell.bin_half, rng2, cell.spawn);
    auto hw2 = makeMujocoHardware(*world, robot, spawn.active);
    const auto t3 = Clock::now();
    TrialContext ctx(*hw2, robot, cell.statics, e.task, cell.perception, e.seed, static_cast<uint64_t>(i));
    ctx.target_half_height = cell.place_target_half_height;
    runPickAndPlace(ctx, cell.T_world_place_target);
    const auto t4 = Clock::now();
    wall_chain += secs(t3, t4);
    ratio.push_back(secs(t1, t2) / secs(t3, t4));
    same += ctx.out.success == by_tree.success && std::abs(ctx.out.sim_time - by_tree.sim_time) < 1e-9;

    world->restoreState(start);
    const auto t5 = Clock::now();
    sim_replay += world->replayControls(log, &counts_new);
    wall_replay += secs(t5, Clock::now());
    steps += static_cast<long>(log.size() / world->controlsPerStep());

    // The same trial on today's model: the parked pool and the scene's own numerics. Controls are
    // held through a control period, so a log at a finer timestep is thinned to the scene's.
    const int stride = static_cast<int>(std::lround(kControlPeriod / world->timestep()));
    world->setPhysics(PhysicsOptions::sceneAsIs(), e.file);
    const int pool_stride = static_cast<int>(std::lround(kControlPeriod / world->timestep()));
    const int nu = world->controlsPerStep();
    const std::vector<double>* pool_log = &log;
    std::vector<double> thinned;
    if (stride != pool_stride) {
      for (size_t k = 0; k + nu <= log.size(); k += static_cast<size_t>(nu) * stride / pool_stride)
        thinned.insert(thinned.end(), log.begin() + static_cast<long>(k), log.begin() + static_cast<long>(k) + nu);
      pool_log = &thinned;
    }
    Rng rng3 = Rng::stream(e.seed, i, Purpose::kScene);
    spawnObjects(*world, robot, cell.T_world_bin, cell.bin_half, rng3, pooled);
    const auto t6 = Clock::now();
    sim_pool += world->replayControls(*pool_log, &counts_pool);
    wall_pool += secs(t6, Clock::now());
    world->setPhysics(e.physics, e.file);
  }
  std::filesystem::remove_all(logs);
  if (trials == 0)  // every spawn failed (the settings make a bin no object can rest in): nothing to time
    return "Harness benchmark\n  command:     " + command_line + "\n  no trial could be spawned in " +
           std::to_string(e.trials) + " attempts: nothing measured\n";
  const double wall_total = secs(t_all, Clock::now());
  std::string cpu = "unknown";
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) {
      cpu = line.substr(line.find(':') + 2);
      break;
    }
  const TreeCost& c = runner.cost();
  // The tree's own cost: the ticks' wall time outside the leaf nodes (traversal, ports and
  // blackboard, attribute scripts, the transitions recorded for the log); the leaves' work is the
  // actions', which the tree-less chain does too.
  const double tree_own = std::max(0.0, c.tick_seconds - c.leaf_seconds);
  std::sort(ratio.begin(), ratio.end());
  const double median_ratio = ratio.empty() ? 0 : ratio[ratio.size() / 2];
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(2);
  o << "Harness benchmark\n";
  o << "  command:     " << command_line << "\n";
  o << "  experiment:  " << e.file << " (" << trials << " trials, seed " << e.seed << ", " << e.hardware << ", tree "
    << e.tree_path << ")\n";
  o << "  machine:     " << cpu << ", " << std::thread::hardware_concurrency() << " cores, MuJoCo " << mujocoVersion()
    << ", one worker\n";
  o << "  successes:   " << ok << "/" << trials << " (the tree-less chain, one pick and place, gave the same success and "
    << "simulated time on " << same << " of " << trials
    << (same < trials ? ": the tree does other work than the chain, so the comparison lines below compare different work)"
                      : ")")
    << "\n\n";
  o << "  full trials (spawn + settle + tree + evaluate): " << trials / wall_full << " trials/s\n";
  o << "  task through the tree:                          " << sim_task / wall_tree << " simulated s per wall s ("
    << sim_task << " sim s in " << wall_tree << " s)\n";
  auto per_step = [](const SimWorld::ReplayCounts& k) {
    std::ostringstream t;
    t.setf(std::ios::fixed);
    t.precision(1);
    const double n = static_cast<double>(std::max(1L, k.steps));
    t << static_cast<double>(k.dof) / n << " dof; per step " << k.contacts / n << " contacts, " << k.rows / n << " constraint rows, " << k.iterations / n
      << " solver iterations";
    if (k.asleep > 0) t << "; objects asleep " << 100.0 * static_cast<double>(k.asleep) / static_cast<double>(k.objects) << "% of the time";
    return t.str();
  };
  o << "  pure MuJoCo, same scenes and controls:          " << sim_replay / wall_replay << " simulated s per wall s ("
    << sim_replay << " sim s, " << steps << " steps in " << wall_replay << " s: " << steps / wall_replay << " steps/s)\n"
    << "    the model holds the objects in play only" << (e.physics.midphase ? ", the mid-phase" : "")
    << (e.physics.sleep ? ", sleeping" : "") << ": " << per_step(counts_new) << "\n";
  o << "  the same on the parked-pool model:              " << sim_pool / wall_pool << " simulated s per wall s ("
    << counts_pool.steps / wall_pool << " steps/s)\n"
    << "    " << pooled.pool << " cubes, those out of play parked on the floor, the scene's numerics as they were (no mid-phase, "
       "no sleeping, no velocity-product term): " << per_step(counts_pool) << "\n";
  o << "  physics speed-up over the parked-pool model:    " << (sim_replay / wall_replay) / (sim_pool / wall_pool)
    << "x (simulated s per wall s, same trials, same controls)\n";
  o.precision(3);
  o << "  harness overhead (tree run wall / pure stepping wall for the same simulated time): "
    << (wall_tree / sim_task) / (wall_replay / sim_replay) << "x\n\n";
  o.precision(2);
  o << "  behavior tree (" << c.ticks << " ticks, " << c.transitions << " transitions, " << c.logs << " .db3 logs):\n";
  o << "    inside ticks " << 1e3 * c.tick_seconds << " ms, of which inside the leaf nodes (actions and conditions) "
    << 1e3 * c.leaf_seconds << " ms, their planning and perception " << 1e3 * c.compute_seconds << " ms\n";
  // Shares of a whole trial (spawn, settle, the tree's run, evaluation: what a campaign's worker
  // spends on it) and of the tree's run alone (the stricter figure).
  auto shares = [&](double seconds) {
    std::ostringstream t;
    t.setf(std::ios::fixed);
    t.precision(2);
    t << 100 * seconds / wall_full << "% of the trials' wall time (" << 100 * seconds / wall_tree << "% of the tree's run alone)";
    return t.str();
  };
  o << "    the tree's own cost: " << 1e6 * tree_own / std::max(1L, c.ticks) << " us per tick, " << 1e3 * tree_own / std::max(1L, trials)
    << " ms per trial = " << shares(tree_own) << "\n";
  o << "    writing the SQLite logs: " << 1e3 * c.log_seconds / std::max(1L, c.logs) << " ms per trial = " << shares(c.log_seconds)
    << "\n";
  o << "    together: " << shares(tree_own + c.log_seconds) << "\n";
  o << "    same trials without the tree (the chain of the same actions): " << wall_chain << " s against " << wall_tree
    << " s with it; median per-trial ratio " << median_ratio << "\n";
  // Rendering: the last trial's final state through the experiment's camera, each image kind on
  // its own and all three, after one warm-up render (the GPU context and the model's upload).
  {
    std::string why;
    auto r = Renderer::create(e.render.egl, &why);
    if (!r) {
      o << "  rendering: none (" << why << ")\n";
    } else {
      const CameraModel cam = r->camera(*world, e.render.camera, e.render.width, e.render.height, e.file);
      const auto tw = Clock::now();
      r->render(*world, cam, kRgb);
      const double warm = secs(tw, Clock::now());
      o << "  rendering (" << r->description() << "), camera " << cam.name << " " << cam.width << "x" << cam.height
        << ", first frame " << 1e3 * warm << " ms, then per frame:";
      const std::pair<const char*, unsigned> kinds[] = {
          {"rgb", kRgb}, {"depth", kDepth}, {"segmentation", kSegmentation}, {"all three", kRgb | kDepth | kSegmentation}};
      for (const auto& [name, kind] : kinds) {
        const int n = 30;
        const auto t0 = Clock::now();
        for (int k = 0; k < n; ++k) r->render(*world, cam, kind);
        o << " " << name << " " << 1e3 * secs(t0, Clock::now()) / n << " ms" << (kind == (kRgb | kDepth | kSegmentation) ? "\n" : ",");
      }
      // Camera perception — depth image in, ranked grasp candidates out — on the experiment's
      // first scene spawned afresh (bin clearing's: a pile of ten), at 640x480 and at the
      // experiment's resolution: the sensor's noise, each step of the detection, and the grasp
      // candidates of every object found (scored against the others and what no detection explains).
      Rng scene_rng = Rng::stream(e.seed, 0, Purpose::kScene);
      const SpawnResult pile = spawnObjects(*world, robot, cell.T_world_bin, cell.bin_half, scene_rng, cell.spawn);
      world->updateKinematics();
      const GraspOptions go = graspOptionsFor(robot.spec().gripper, e.task);
      std::vector<std::pair<int, int>> sizes = {{640, 480}};
      if (e.perception.camera_width != 640 || e.perception.camera_height != 480)
        sizes.push_back({e.perception.camera_width, e.perception.camera_height});
      for (const auto& [width, height] : sizes) {
        const CameraModel pcam = r->camera(*world, e.perception.camera, width, height, e.file);
        const int n = 10;
        double t_render = 0, t_noise = 0, t_grasps = 0, t_check = 0;
        CellRegistrationOptions ro;
        ro.T_world_bin = cell.perception.T_world_crop;
        ro.bin_half = cell.perception.crop_half;
        ro.depth_sigma_k = e.perception.noise.k;
        ro = checkOptions(ro);
        const std::vector<Obstacle> statics = world->staticObstacles();
        bool checked = true;
        CameraPerceptionResult sum;
        size_t found = 0, candidates = 0;
        // The model-free detector as a trial runs it (the task's options, the perception's crop),
        // its seeds from their own stream.
        const CloudGraspOptions cgo = cloudGraspOptionsFor(robot.spec().gripper, e.task, cell.perception);
        const Vec3 preferred_x = robot.fk(robot.home()).linear().col(0);
        double t_cloud_noise = 0, t_segment = 0, t_cloud = 0, t_hands = 0;
        size_t cloud_points = 0, cloud_candidates = 0, cloud_segments = 0;
        int cloud_seeds = 0, cloud_repeated = 0, cloud_hands = 0;
        // Objects with no model (camera mode): a trial's view is segmented first, and the segments'
        // columns (and the patches no segment explains) are the boxes the hands must keep out of.
        const bool segmented = cell.perception.unknown_objects;
        const SegmentationOptions so = segmentationOptions(cell.perception);
        Rng cloud_noise(2);  // its own draws: the known-object line's stay as they were
        Rng rng(1);
        CameraPerceptionOptions co;
        co.T_world_crop = cell.perception.T_world_crop;
        co.crop_half = cell.perception.crop_half;
        co.crop_height = cell.perception.crop_height;
        co.depth_sigma_k = e.perception.noise.k;
        for (int k = 0; k < n; ++k) {
          const auto a = Clock::now();
          Frame f = r->render(*world, pcam, kDepth);
          const auto b = Clock::now();
          applyDepthNoise(f, e.perception.noise, rng);
          const auto t_check0 = Clock::now();
          checked = checked && registerCameraToCell(f, statics, ro).ok;
          t_check += secs(t_check0, Clock::now());
          const CameraPerceptionResult res = detectKnownObjects(f, cell.perception.shapes, co, rng);
          const auto t_d = Clock::now();
          candidates = 0;
          for (const CameraDetection& det : res.detections) {
            std::vector<Obstacle> others = res.unexplained;
            for (const CameraDetection& other : res.detections)
              if (&other != &det) others.push_back(Obstacle{Obstacle::Type::kBox, other.object.half_size, other.object.T_world_object, ""});
            candidates += graspCandidates(det.object, 0.0, Vec3::Zero(), others, go).size();
          }
          t_render += secs(a, b), t_noise += secs(b, t_check0), t_grasps += secs(t_d, Clock::now());
          sum.seconds.cloud += res.seconds.cloud, sum.seconds.floor += res.seconds.floor, sum.seconds.faces += res.seconds.faces;
          sum.seconds.fit += res.seconds.fit, sum.seconds.unexplained += res.seconds.unexplained;
          found = res.detections.size();
          // The same view again, noised afresh, into the model-free detector.
          Frame g = r->render(*world, pcam, kDepth);
          const auto t_g = Clock::now();
          applyDepthNoise(g, e.perception.noise, cloud_noise);
          t_cloud_noise += secs(t_g, Clock::now());
          CloudGraspOptions view_cgo = cgo;
          if (segmented) {
            // A segment's columns (its convex pieces) as the planner's boxes, as a trial hands them.
            auto columns = [](const ObjectState& ob, int owner, std::vector<OwnedBox>& boxes) {
              for (const ConvexPiece& piece : *ob.pieces) {
                const PieceBox pb = pieceBox(piece);
                boxes.push_back({ob.T_world_object * pb.T_object_box, pb.half, owner});
              }
            };
            const auto t_s = Clock::now();
            const Segmentation seg = segmentDepth(g, so);
            for (const Segment& sg : seg.segments) {
              const int owner = static_cast<int>(view_cgo.objects.size());
              view_cgo.objects.push_back(segmentObject(sg, so.T_world_region));
              columns(view_cgo.objects.back(), owner, view_cgo.boxes);
            }
            for (const Segment& sg : seg.small)
              columns(segmentObject(sg, so.T_world_region), -1, view_cgo.boxes);
            t_segment += secs(t_s, Clock::now());
            cloud_segments = seg.segments.size();
          }
          Rng grasp_rng = Rng::stream(e.seed, static_cast<uint64_t>(k), Purpose::kGrasp);
          const CloudGraspResult cg = cloudGrasps(g, view_cgo, preferred_x, grasp_rng);
          t_cloud += cg.seconds.cloud, t_hands += cg.seconds.hands;
          cloud_points = cg.cloud.points.size(), cloud_candidates = cg.candidates.size(), cloud_seeds = cg.seeds, cloud_repeated = cg.seeds_repeated, cloud_hands = cg.hands;
        }
        const auto& t = sum.seconds;
        const double detect = t.cloud + t.floor + t.faces + t.fit + t.unexplained;
        o << "  camera perception, " << pcam.width << "x" << pcam.height << " depth, " << pile.active.size()
          << " objects spawned (trial 0's scene): render " << 1e3 * t_render / n << " ms; depth image in, grasps out "
          << 1e3 * (t_noise + t_check + detect + t_grasps) / n << " ms = sensor noise " << 1e3 * t_noise / n << " + extrinsics check "
          << 1e3 * t_check / n << (checked ? "" : " (failed)") << " + cloud " << 1e3 * t.cloud / n
          << " + floor " << 1e3 * t.floor / n << " + faces " << 1e3 * t.faces / n << " + fit " << 1e3 * t.fit / n << " + unexplained "
          << 1e3 * t.unexplained / n << " + grasp candidates " << 1e3 * t_grasps / n << " ms (" << found << " objects found, " << candidates
          << " candidates)\n";
        o << "  model-free grasps, " << pcam.width << "x" << pcam.height << " depth: depth image in, ranked grasp candidates out "
          << 1e3 * (t_cloud_noise + t_segment + t_cloud + t_hands) / n << " ms = sensor noise " << 1e3 * t_cloud_noise / n;
        if (segmented) o << " + segmentation " << 1e3 * t_segment / n;
        o << " + cloud " << 1e3 * t_cloud / n << " + hands (with the normals they read) " << 1e3 * t_hands / n << " ms (";
        if (segmented) o << cloud_segments << " segments, ";
        o << cloud_points << " points, " << cloud_seeds << " seeds (" << cloud_repeated << " drawn again), " << cloud_hands << " hands, " << cloud_candidates << " candidates)\n";
      }
    }
  }
  o.precision(1);
  o << "  total bench wall time: " << wall_total << " s\n";
  return o.str();
}

}  // namespace mm
