// One trial through the experiment's behavior tree: the tree built fresh from the loaded document,
// the place target put on its blackboard as `place_target` (the source's tree reads it), run on
// simulated time, the result evaluated in the simulator, and the tree's transitions written as a
// .db3 when the campaign keeps this trial's log.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "bt/factory.h"
#include "bt/manip_nodes.h"
#include "campaign/experiment.h"

namespace mm {

class ExternalComponent;
class Hardware;
class Renderer;
class SimWorld;

/// What every trial of a campaign shares (read from the robot and the scene once).
struct Cell {
  const RobotModel* robot = nullptr;
  std::vector<Obstacle> statics;
  PerceptionOptions perception;  ///< the experiment's, with the bin's crop box and hardcoded pose
  Pose T_world_place_target = Pose::Identity();  ///< where the placed object rests (its centre: the first kind's half height up)
  double place_target_half_height = 0;           ///< [m] the first kind's, which the place target's height assumes
  Pose T_world_bin = Pose::Identity();           ///< the scene's bin_region site (spawning)
  Vec3 bin_half = Vec3::Zero();
  SpawnOptions spawn;  ///< the experiment's, its object catalogue loaded
};

/// The experiment's scene with its robot mounted and its physics options applied.
std::unique_ptr<SimWorld> loadWorld(const Experiment& e, const RobotModel& robot);

/// The cell of experiment `e` as the scene describes it (sites bin_region and place_target) with
/// the experiment's object catalogue. Throws InputError for an unreadable catalogue or unknown kind.
Cell makeCell(const Experiment& e, const RobotModel& robot, const SimWorld& world);

/// Wall-clock accounting of the tree itself (for the benchmark), summed over the trials run.
struct TreeCost {
  double tick_seconds = 0;     ///< inside ticks, the actions' planning and perception included
  double compute_seconds = 0;  ///< the actions' planning and perception (the stages' compute time)
  double leaf_seconds = 0;     ///< inside the leaf nodes (actions and conditions), their planning included
  double log_seconds = 0;      ///< recording transitions is inside the ticks; this is writing .db3 files
  long ticks = 0, transitions = 0, logs = 0;
};

/// One worker's trial runner (not thread-safe; one per worker).
class TrialRunner {
 public:
  /// `log_dir` receives trial_<N>.db3 files; `date` is the campaign's start ("YYYY-MM-DD HH:MM:SS").
  TrialRunner(const Experiment& e, const Cell& cell, const bt::TreeDocument& tree, std::string log_dir, std::string date);
  ~TrialRunner();
  TrialRunner(const TrialRunner&) = delete;  // the nodes hold a reference to env_
  TrialRunner& operator=(const TrialRunner&) = delete;
  /// Runs trial `trial` on `hw` (objects spawned). Returns its outcome; `bt_log` gets the .db3
  /// path when one was written.
  TrialOutcome run(Hardware& hw, SimWorld& world, uint64_t trial, std::string& bt_log);
  /// A replay: the external component (if the tree asks one) answers from these recorded calls
  /// instead of being started (ExternalComponent::replay).
  void replayExternal(std::vector<ExternalCallRecord> calls);
  /// Called with each camera image a trial takes (camera mode, a renderer set), as the sensor gave
  /// it (its noise drawn), and the world at that moment: a dataset's views (BopWriter).
  void setViewTap(std::function<void(const SimWorld&, const Frame&)> tap) { view_tap_ = std::move(tap); }
  const TreeCost& cost() const { return cost_; }
  /// Renders the trials `options` asks for with `renderer` into `dir`/trial_<N>/ (null: none).
  void setRenderer(Renderer* renderer, std::string dir, const RenderOptions& options);
  /// The files the last run() rendered, relative to its trial's folder.
  const std::vector<std::string>& rendered() const { return rendered_; }

 private:
  const Experiment& e_;
  const Cell& cell_;
  const bt::TreeDocument& doc_;
  bool needs_camera_ = false;  ///< needsCamera(e_, doc_)
  std::string log_dir_, date_, xml_;
  bt::TaskNodeEnv env_;
  bt::Factory factory_;
  TreeCost cost_;
  Renderer* renderer_ = nullptr;
  std::function<void(const SimWorld&, const Frame&)> view_tap_;
  std::string render_dir_;
  RenderOptions render_;
  std::vector<std::string> rendered_;
  std::unique_ptr<ExternalComponent> external_;  ///< the tree asks one: started at its first call, kept across trials
};

/// A process's rendering: the renderer (null when rendering is off or impossible) and the options
/// it can honour (no video without ffmpeg). What was given up is said on stderr.
struct RenderSetup {
  std::unique_ptr<Renderer> renderer;
  RenderOptions options;
  RenderSetup();
  ~RenderSetup();
  RenderSetup(RenderSetup&&) noexcept;
};
RenderSetup setUpRendering(const Experiment& e);

/// A trial's renders folder under `dir`: trial_<N> with N in six digits.
std::string trialRenderDir(const std::string& dir, uint64_t trial);

/// Loads and checks the experiment's tree with the node library (InputError: exit code 2).
bt::TreeDocument loadTree(const Experiment& e);

/// The node library (not BT.CPP's built-ins) as a Markdown table: node, kind, ports, meaning.
std::string nodeLibraryMarkdown();

}  // namespace mm
