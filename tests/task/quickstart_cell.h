// The quickstart's cell for the task layer's tests: its experiment, the Panda, the world, the
// cell (its static parts as the planner knows them) and the MuJoCo hardware, and a part by name.
#pragma once
#include <memory>
#include <string>

#include "campaign/experiment.h"
#include "campaign/trial.h"
#include "core/rng.h"
#include "kinematics/ik.h"
#include "sim/hardware.h"
#include "sim/sim_world.h"
#include "task/trial_context.h"

namespace mm::testing_task {

struct QuickstartCell {
  Experiment e = loadExperiment("experiments/quickstart.yaml", {});
  RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  std::unique_ptr<SimWorld> world = loadWorld(e, robot);
  Cell cell = makeCell(e, robot, *world);
  std::unique_ptr<Hardware> hw = makeMujocoHardware(*world, robot, {});

  QuickstartCell() = default;
  QuickstartCell(const QuickstartCell&) = delete;  // the cell and the hardware point at robot and world
  QuickstartCell& operator=(const QuickstartCell&) = delete;

  /// Trial 0's context in this cell, with the task options `o`.
  TrialContext context(const TaskOptions& o) const { return TrialContext(*hw, robot, cell.statics, o, cell.perception, e.seed, 0); }

  /// The static part `name` (nullptr: none).
  const Obstacle* part(const std::string& name) const {
    for (const Obstacle& s : cell.statics)
      if (s.name == name) return &s;
    return nullptr;
  }
};

/// The arm's joints with the TCP at T_tcp, by ctx's IK solver with the request `base` asks for,
/// the solution nearest `seed`, into q (left as it is when there is none); whether there is one.
inline bool ikNearest(TrialContext& ctx, const IkRequest& base, const Pose& T_tcp, const VecX& seed, Rng& rng, VecX& q) {
  IkRequest req = base;
  req.target = T_tcp;
  req.seed = seed;
  req.nearest = true;
  const IkResult r = ctx.ik->solve(req, rng);
  if (r.ok()) q = r.q();
  return r.ok();
}

}  // namespace mm::testing_task
