// The MJCF robot loader (sim/mjcf_robot.cc): our checks, then MuJoCo compiles the file. Run for a
// fixed time (a compile per input). The companion gives velocity, as for a published file.
#include "fuzz_common.h"
#include "sim/mjcf_robot.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string companion = [] {
    const std::string text = "gripper: " + mm::fuzz::repo("robots/grippers/panda_hand.yaml") + "\n";
    return mm::fuzz::asFile(reinterpret_cast<const uint8_t*>(text.data()), text.size(), "robot.xml.yaml");
  }();
  const std::string path = mm::fuzz::asFile(data, size, "robot.xml");
  mm::fuzz::expectOnlyInputErrors([&] { mm::loadAnyRobotSpec(path, ""); });
  return 0;
}
