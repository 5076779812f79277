// The scene loader (sim/: our checks, the robot mounted, MuJoCo compiles the composed model). Run
// for a fixed time (a compile per input). The robot is the stock Panda.
#include "campaign/trial.h"
#include "fuzz_common.h"
#include "robot/robot_model.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const mm::RobotModel robot = mm::RobotModel::load(mm::fuzz::repo("robots/panda/panda.yaml"));
  const std::string path = mm::fuzz::asFile(data, size, "scene.xml");
  static mm::Experiment e = [&] {
    mm::Experiment x = mm::loadExperiment(mm::fuzz::repo("experiments/quickstart.yaml"), {"scene=" + path}, {}, false);
    return x;
  }();
  mm::fuzz::expectOnlyInputErrors([&] {
    const auto world = mm::loadWorld(e, robot);
    mm::makeCell(e, robot, *world);
  });
  return 0;
}
