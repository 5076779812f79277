#include "campaign/experiment.h"

#include <filesystem>

#include "core/error.h"

namespace mm {

std::vector<ParamDecl> experimentParams() {
  using K = ParamDecl::Kind;
  const double inf = std::numeric_limits<double>::infinity();
  return {
      {"name", K::kString, "quickstart", -inf, inf, {}, "", "campaign name; results go to results/<name>/ unless --out"},
      {"trials", K::kInt, "100", 1, 1e7, {}, "", "number of trials (--trials overrides)"},
      {"seed", K::kInt, "1", 0, 9.007e15, {}, "", "campaign seed; every random choice derives from (seed, trial, purpose)"},
      {"hardware", K::kChoice, "mujoco", -inf, inf, {"mujoco", "mock"}, "", "mujoco: physics; mock: joints follow commands exactly"},
      {"robot", K::kString, "robots/panda/panda.yaml", -inf, inf, {}, "", "robot YAML (a path in the file is relative to the file; the default, to the project root)"},
      {"scene", K::kString, "scenes/bin_table.xml", -inf, inf, {}, "", "scene MJCF (includes the robot); paths as for robot"},
      {"tree", K::kString, "experiments/trees/mini_manip.xml", -inf, inf, {}, "", "behavior tree (BT.CPP v4 XML) run for each trial; paths as for robot. The default is the source's MiniManip tree"},
      {"bt.tick_period", K::kDouble, "0.1", 0.001, 10.0, {}, "s", "simulated time between ticks (an action that finishes wakes the tree at once)"},
      {"bt.time_budget", K::kDouble, "120", 1.0, 1e6, {}, "s", "simulated time a trial may take; a tree still running then ends as TIMEOUT"},
      {"bt.log", K::kChoice, "failed_or_recovered", -inf, inf, {"none", "failed_or_recovered", "all"}, "", "which trials keep their tree's transitions as results/<name>/bt/trial_<N>.db3 (BT.CPP's SqliteLogger schema, Groot2)"},
      {"place.rows", K::kInt, "1", 1, 20, {}, "", "rows (along y) of the place grid ComputePlacePosition fills, centred on the scene's place_target, nearest slots first"},
      {"place.columns", K::kInt, "3", 1, 20, {}, "", "columns (along x) of the place grid (the quickstart tray holds a row of three 5 cm cubes)"},
      {"place.pitch", K::kDouble, "0.06", 0.02, 0.5, {}, "m", "distance between neighbouring slots of the place grid"},
      {"jobs", K::kInt, "1", 1, 64, {}, "", "parallel workers (outcomes do not depend on it)"},
      {"progress", K::kChoice, "auto", -inf, inf, {"auto", "bar", "lines", "none"}, "", "progress display; auto: a bar on a terminal, lines otherwise"},
      {"objects.count_min", K::kInt, "1", 1, 6, {}, "", "fewest objects in the bin"},
      {"objects.count_max", K::kInt, "3", 1, 6, {}, "", "most objects in the bin (the scene holds 6)"},
      {"objects.wall_margin", K::kDouble, "0.07", 0.0, 0.1, {}, "m", "object centers keep this far from the bin walls"},
      {"objects.min_spacing", K::kDouble, "0.11", 0.05, 0.3, {}, "m", "least distance between object centers"},
      {"objects.settle_time", K::kDouble, "0.3", 0.0, 5.0, {}, "s", "simulated settling after spawning"},
      {"perception.mode", K::kChoice, "ground_truth", -inf, inf, {"hardcoded", "ground_truth"}, "", "hardcoded: assume the object at the bin center, yaw 0; ground_truth: simulator poses"},
      {"perception.noise_position", K::kDouble, "0.0", 0.0, 0.05, {}, "m", "std of Gaussian noise on perceived x and y"},
      {"perception.noise_yaw", K::kDouble, "0.0", 0.0, 0.5, {}, "rad", "std of Gaussian noise on perceived yaw"},
      {"grasp.mode", K::kChoice, "friction", -inf, inf, {"friction", "weld"}, "", "friction: held by finger force; weld: attached on grasp (the source's attach plugin)"},
      {"grasp.force", K::kDouble, "40", 1.0, 70.0, {}, "N", "finger force limit while grasping (the hand's limit is 70 N)"},
      {"grasp.max_candidates", K::kInt, "8", 1, 64, {}, "", "grasp candidates tried before the pick fails"},
      {"grasp.finger_margin", K::kDouble, "0.012", 0.002, 0.04, {}, "m", "fingers open this much wider than the object's half width before the approach"},
      {"grasp.depth", K::kDouble, "0.0", -0.02, 0.02, {}, "m", "TCP height above the object's center at the grasp"},
      {"motion.approach_distance", K::kDouble, "0.10", 0.02, 0.3, {}, "m", "pre-grasp and pre-place height above the grasp and place poses"},
      {"motion.lift_height", K::kDouble, "0.15", 0.02, 0.4, {}, "m", "straight lift after the grasp"},
      {"motion.retreat_distance", K::kDouble, "0.10", 0.02, 0.3, {}, "m", "straight retreat after the release"},
      {"motion.place_clearance", K::kDouble, "0.005", 0.0, 0.05, {}, "m", "object bottom above the tray at the release"},
      {"motion.velocity_scaling", K::kDouble, "0.5", 0.01, 1.0, {}, "", "fraction of the joint velocity limits"},
      {"motion.acceleration_scaling", K::kDouble, "0.5", 0.01, 1.0, {}, "", "fraction of the joint acceleration limits"},
      {"motion.cartesian_speed", K::kDouble, "0.2", 0.01, 1.0, {}, "m/s", "TCP speed limit on straight-line moves"},
      {"motion.cartesian_acceleration", K::kDouble, "1.0", 0.05, 5.0, {}, "m/s^2", "TCP acceleration limit on straight-line moves"},
      {"kinematics.solver", K::kChoice, "analytic", -inf, inf, {"analytic", "hybrid", "dls", "kdl", "kdl_restarts", "trac_ik", "trac_ik_distance"}, "", "IK solver for grasp and place poses (see the IK comparison in the README)"},
      {"planning.planner", K::kChoice, "RRTConnect", -inf, inf, {"RRTConnect", "RRTstar", "InformedRRTstar", "BITstar", "ABITstar", "AITstar", "PRMstar", "LazyPRMstar", "KPIECE1"}, "", "OMPL planner (optimizing ones stop at their first solution; planners other than RRTConnect repeat exactly only with jobs: 1)"},
      {"planning.checker", K::kChoice, "spheres+fcl", -inf, inf, {"spheres", "spheres+fcl", "fcl"}, "", "collision checker: our spheres (conservative), spheres confirmed by FCL (exact), or FCL"},
      {"planning.time_parameterization", K::kChoice, "jerk_limited", -inf, inf, {"trapezoidal", "jerk_limited_stop", "jerk_limited", "totg"}, "", "time parameterization of joint-space paths: jerk_limited passes through waypoints, jerk_limited_stop and trapezoidal rest at each, totg blends corners within 0.05 rad (samples off the planned path are collision-checked)"},
      {"planning.time_limit", K::kDouble, "5.0", 0.01, 600.0, {}, "s", "wall-clock cap per planning call (reaching it is recorded)"},
      {"planning.optimizer", K::kChoice, "none", -inf, inf, {"none", "chomp"}, "", "optimizing post-processor after the planner (CHOMP-style; time-parameterize its dense paths with totg)"},
      {"planning.padding", K::kDouble, "0.01", 0.0, 0.1, {}, "m", "robot inflation against the world"},
      {"planning.simplify", K::kBool, "true", -inf, inf, {}, "", "shortcut and reduce the planned path"},
      {"planning.resolution", K::kDouble, "0.02", 0.001, 0.2, {}, "rad", "edge validation step"},
      {"success.position_tolerance", K::kDouble, "0.02", 0.001, 0.2, {}, "m", "horizontal distance from the place target counted as placed"},
      {"success.orientation_tolerance", K::kDouble, "0.1745", 0.001, 3.1416, {}, "rad", "orientation error counted as placed (about its symmetry)"},
      {"success.settle_time", K::kDouble, "0.5", 0.0, 5.0, {}, "s", "simulated rest before the placed object is measured"},
  };
}

Experiment loadExperiment(const std::string& path, const std::vector<std::string>& sets) {
  Experiment e;
  ParamSet& p = e.params;
  p.loadYamlFile(path);
  for (const std::string& s : sets) {
    const auto eq = s.find('=');
    if (eq == std::string::npos || eq == 0) throw InputError("--set " + s, "expected key=value");
    p.set(s.substr(0, eq), s.substr(eq + 1), "--set " + s.substr(0, eq));
  }
  e.file = path;
  e.name = p.getString("name");
  e.trials = p.getInt("trials");
  e.seed = static_cast<uint64_t>(p.getInt("seed"));
  e.hardware = p.getString("hardware");
  // A path written in the file is relative to the file; one given by --set, to the working
  // directory; a default, to the project root (so a copied experiment file runs anywhere).
  const auto dir = std::filesystem::path(path).parent_path();
  auto resolve = [&](const std::string& key) {
    const std::filesystem::path v = p.getString(key);
    if (v.is_absolute()) return v.lexically_normal().string();
    for (const std::string& s : sets)
      if (s.rfind(key + "=", 0) == 0) return v.lexically_normal().string();
    if (p.wasSet(key)) return (dir / v).lexically_normal().string();
    return (std::filesystem::path(MINIMANIP_SOURCE_DIR) / v).lexically_normal().string();
  };
  e.robot_path = resolve("robot");
  e.scene_path = resolve("scene");
  e.tree_path = resolve("tree");
  e.tree_run.tick_period = p.getDouble("bt.tick_period");
  e.tree_run.time_budget = p.getDouble("bt.time_budget");
  e.bt_log = p.getString("bt.log");
  e.jobs = static_cast<int>(p.getInt("jobs"));
  e.progress = p.getString("progress");

  e.spawn.count_min = static_cast<int>(p.getInt("objects.count_min"));
  e.spawn.count_max = static_cast<int>(p.getInt("objects.count_max"));
  if (e.spawn.count_min > e.spawn.count_max)
    throw InputError(path, "objects.count_min (" + std::to_string(e.spawn.count_min) + ") must be <= objects.count_max (" +
                               std::to_string(e.spawn.count_max) + ")");
  e.spawn.wall_margin = p.getDouble("objects.wall_margin");
  e.spawn.min_spacing = p.getDouble("objects.min_spacing");
  e.spawn.settle_time = p.getDouble("objects.settle_time");
  e.spawn.physics = e.hardware == "mujoco";

  e.perception.mode = p.getString("perception.mode") == "hardcoded" ? PerceptionMode::kHardcoded : PerceptionMode::kGroundTruth;
  e.perception.noise_position = p.getDouble("perception.noise_position");
  e.perception.noise_yaw = p.getDouble("perception.noise_yaw");

  TaskOptions& t = e.task;
  t.weld = p.getString("grasp.mode") == "weld";
  t.grasp_force = p.getDouble("grasp.force");
  t.max_grasp_candidates = static_cast<int>(p.getInt("grasp.max_candidates"));
  t.grasp.depth = p.getDouble("grasp.depth");
  t.finger_margin = p.getDouble("grasp.finger_margin");
  t.approach_distance = p.getDouble("motion.approach_distance");
  t.lift_height = p.getDouble("motion.lift_height");
  t.retreat_distance = p.getDouble("motion.retreat_distance");
  t.place_clearance = p.getDouble("motion.place_clearance");
  t.scaling.velocity = p.getDouble("motion.velocity_scaling");
  t.scaling.acceleration = p.getDouble("motion.acceleration_scaling");
  t.cartesian.speed = p.getDouble("motion.cartesian_speed");
  t.cartesian.acceleration = p.getDouble("motion.cartesian_acceleration");
  t.ik_solver = p.getString("kinematics.solver");
  t.planner.planner = p.getString("planning.planner");
  t.planner.time_limit = p.getDouble("planning.time_limit");
  t.planner.simplify = p.getBool("planning.simplify");
  t.planner.resolution = p.getDouble("planning.resolution");
  t.padding = p.getDouble("planning.padding");
  t.checker = p.getString("planning.checker");
  t.optimizer = p.getString("planning.optimizer");
  t.time_parameterization = p.getString("planning.time_parameterization");
  t.tolerance_position = p.getDouble("success.position_tolerance");
  t.tolerance_orientation = p.getDouble("success.orientation_tolerance");
  t.settle_time = p.getDouble("success.settle_time");
  t.place_rows = static_cast<int>(p.getInt("place.rows"));
  t.place_columns = static_cast<int>(p.getInt("place.columns"));
  t.place_pitch = p.getDouble("place.pitch");
  return e;
}

}  // namespace mm
